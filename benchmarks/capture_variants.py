"""Which way of putting the MuJoCo Warp physics inside the env's whole-step CUDA graph works, and how fast.

Each variant runs in its own process (a failed capture leaves CUDA RNG state unusable in that process):

    python benchmarks/capture_variants.py --env mt10_rand --num-envs 24576
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

VARIANTS = [
    ("nested", False), ("nested", True), ("external", True), ("unrolled", False), ("unrolled", True),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--env", default="mt10_rand")
    parser.add_argument("--num-envs", default="24576")
    parser.add_argument("--steps", default="200")
    args = parser.parse_args()
    for style, one_stream in VARIANTS:
        env = dict(os.environ, MTBENCH_INLINE_STYLE=style)
        cmd = [sys.executable, "benchmarks/env_throughput.py", "--env", args.env, "--num-envs", args.num_envs,
               "--steps", args.steps] + (["--one-stream"] if one_stream else [])
        out = subprocess.run(cmd, env=env, capture_output=True, text=True)
        rows = [line for line in out.stdout.splitlines() if line.startswith(f"| {args.env}")]
        failed = "capture failed" in out.stderr
        print(f"{style:9s} {'one stream' if one_stream else 'streams':10s} capture "
              f"{'FAILED' if failed else 'ok':6s} {rows[-1] if rows else out.stderr[-300:]}", flush=True)


if __name__ == "__main__":
    main()
