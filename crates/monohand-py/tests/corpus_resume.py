"""`monohand.daft.track_corpus` over the videos given, into OUT (the job the resume tests kill),
on Daft's native runner or on a local Ray of 2 CPUs. Exit status 4 if the output could not
be written (`CorpusOutputError`, said on stderr).

    python corpus_resume.py native|ray OUT VIDEO...
"""

import os
import sys

import daft

if sys.argv[1] == "ray":
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    daft.set_runner_ray()
else:
    daft.set_runner_native()
import monohand.daft as mhd  # noqa: E402

code = 0
try:
    mhd.track_corpus(sys.argv[3:], sys.argv[2], workers=1 if sys.argv[1] == "native" else None)
except mhd.CorpusOutputError as e:
    print(f"errno {e.errno}: {e}", file=sys.stderr)
    code = 4  # as `monohand run`: an output could not be written
if sys.argv[1] == "ray":
    ray.shutdown()
sys.stdout.flush()
sys.stderr.flush()
os._exit(code)  # Daft's native runner can crash the interpreter as it exits (corpus_job.py)
