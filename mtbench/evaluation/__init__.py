"""Evaluation of trained checkpoints: per-task success tables (sampled and deterministic policy) and videos.

``python examples/eval.py checkpoint=PATH [episodes=N] [deterministic=true] [video=true] ...`` (see
``docs/evaluation.md``). Rendering uses MuJoCo Warp's batch ray tracer on the simulator's device (CPU or CUDA).
"""

from .args import EvalArgs, EvalArgumentError, parse_args
from .episodes import EvalResult, run_episodes
from .policy import EvalPolicy, load_policy, make_eval_env, read_checkpoint
from .render import METAWORLD_CAMERA, CameraSpec, EnvRenderer, WorldRenderer
from .run import EvalReport, evaluate, main
from .video import VideoRecorder, contact_sheet, write_video

__all__ = [
    "CameraSpec",
    "EnvRenderer",
    "EvalArgs",
    "EvalArgumentError",
    "EvalPolicy",
    "EvalReport",
    "EvalResult",
    "METAWORLD_CAMERA",
    "VideoRecorder",
    "WorldRenderer",
    "contact_sheet",
    "evaluate",
    "load_policy",
    "main",
    "make_eval_env",
    "parse_args",
    "read_checkpoint",
    "run_episodes",
    "write_video",
]
