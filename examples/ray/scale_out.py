"""A dataset or an optimizer run on a Ray cluster, with the bytes of a single process.

    # a local cluster on this machine (loopback only), two workers:
    python examples/ray/scale_out.py --local-cpus 2 dataset --out ds --camera IMX174,focal_mm=4 --seeds 0..8 --every 4
    # the cluster this machine belongs to (after `ray start --head` / `ray start --address HEAD:6379`):
    python examples/ray/scale_out.py --address auto optimize --out runs/ga --config optimize.toml

Needs the scene_gen package with Ray (`pip install .[ray]`). See docs/PYTHON.md.
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--address", help="the Ray cluster to join ('auto': the one this machine belongs to)")
    where.add_argument("--local-cpus", type=int, help="start a local loopback-only cluster with this many CPUs")
    jobs = parser.add_subparsers(dest="job", required=True)

    dataset = jobs.add_parser("dataset", help="one Ray task per house seed, then the COCO merge")
    dataset.add_argument("--out", required=True)
    dataset.add_argument("--camera", required=True)
    dataset.add_argument("--seeds", required=True)
    dataset.add_argument("--lighting", default="both", choices=["day", "night", "both"])
    dataset.add_argument("--frames", type=int)
    dataset.add_argument("--every", type=int)
    dataset.add_argument("--max-width", type=int)
    dataset.add_argument("--quality", default="standard", choices=["preview", "standard", "high"])

    optimize = jobs.add_parser("optimize", help="one Ray task per candidate of each generation")
    optimize.add_argument("--out", required=True)
    optimize.add_argument("--config")
    optimize.add_argument("--method", default="ga", choices=["ga", "random"])

    args = parser.parse_args(argv)
    if args.local_cpus is not None:
        # Read by Ray when imported: a Linux node then binds its services to 127.0.0.1 only.
        os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    import ray

    import scene_gen.ray as sgr

    if args.local_cpus is not None:
        ray.init(num_cpus=args.local_cpus, include_dashboard=False)
    else:
        ray.init(address=args.address)

    def report(done: int, planned: int) -> None:
        print(f"{args.job}: {done}/{planned}", file=sys.stderr, flush=True)

    if args.job == "dataset":
        made = sgr.write_dataset(
            args.out,
            args.camera,
            args.seeds,
            lighting=args.lighting,
            frames=args.frames,
            every=args.every,
            max_width=args.max_width,
            quality=args.quality,
            progress=report,
        )
        print(f"dataset of {len(made.seeds)} houses in {made.out}")
    else:
        summary = sgr.optimize(args.out, config=args.config, method=args.method)
        print(f"{args.method}: {summary['evaluations']} evaluations, best fitness {summary['best']['fitness']:.4f}")
    ray.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
