"""Tracks a corpus of videos with `monohand.daft` and writes Parquet: the job the tests run
on Daft's native runner and on a local Ray, and the benchmark times.

    python corpus_job.py --runner native|ray --out DIR VIDEO...
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runner", choices=["native", "ray"], required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--workers", type=int, default=None, help="Ray: CPUs of the local instance")
    ap.add_argument("videos", nargs="+")
    args = ap.parse_args()

    import daft

    if args.runner == "ray":
        import ray

        # A local Ray instance of this machine, started here and stopped at the end.
        ray.init(num_cpus=args.workers, include_dashboard=False, log_to_driver=False)
        daft.set_runner_ray()
    else:
        daft.set_runner_native()

    import monohand.daft as mhd

    start = time.perf_counter()
    df = daft.from_pydict({"path": args.videos, "video": list(range(len(args.videos)))})
    if args.runner == "ray":
        # One partition per video, so that Ray's workers take videos side by side.
        df = df.into_partitions(len(args.videos))
    frames = mhd.track_videos(df, "path")
    frames.write_parquet(args.out)
    seconds = time.perf_counter() - start
    print(json.dumps({"runner": args.runner, "seconds": seconds}))
    if args.runner == "ray":
        import ray

        ray.shutdown()
    # Daft 0.7.26's native runner can crash the interpreter as it exits (SIGSEGV, about 2
    # runs in 9 on a loaded 2-core machine): during Py_FinalizeEx's garbage collection, one
    # of Daft's tokio worker threads frees a Python context object without the GIL
    # (context_tp_dealloc from daft.abi3.so's Arc::drop_slow). Everything is written and
    # closed by now, so leave without finalising the interpreter (docs/python.md).
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
