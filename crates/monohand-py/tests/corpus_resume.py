"""`monohand.daft.track_corpus` over the videos given, into OUT (the job the resume tests kill),
on Daft's native runner or on a local Ray of 2 CPUs.

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

mhd.track_corpus(sys.argv[3:], sys.argv[2], workers=1 if sys.argv[1] == "native" else None)
if sys.argv[1] == "ray":
    ray.shutdown()
sys.stdout.flush()
sys.stderr.flush()
os._exit(0)  # Daft's native runner can crash the interpreter as it exits (corpus_job.py)
