"""Evaluate a trained checkpoint: per-task success (sampled and deterministic policy), return, length; videos.

    python examples/eval.py checkpoint=outputs/<date>/<time>/checkpoints/final.pt
    python examples/eval.py checkpoint=PATH episodes=20 video=true
    python examples/eval.py checkpoint=PATH deterministic=true device=cpu num_envs=12 seed=7 out=eval_out

Arguments are key=value pairs (checkpoint, episodes, deterministic, video, device, num_envs, seed, out,
video_frames, video_size, video_fps, video_grid); see docs/evaluation.md. Writes <out>/eval.md, eval.json,
eval.mcap and, with video=true, <out>/videos/<task>.mp4 (or .gif without ffmpeg) and videos/frames.png.
"""

from __future__ import annotations

import sys

from mtbench.evaluation import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
