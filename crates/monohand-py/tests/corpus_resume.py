"""`monohand.daft.track_corpus` over the videos given, into OUT (the job the resume tests kill).

    python corpus_resume.py OUT VIDEO...
"""

import os
import sys

import daft

daft.set_runner_native()
import monohand.daft as mhd  # noqa: E402

mhd.track_corpus(sys.argv[2:], sys.argv[1], workers=1)
sys.stdout.flush()
sys.stderr.flush()
os._exit(0)  # Daft's native runner can crash the interpreter as it exits (corpus_job.py)
