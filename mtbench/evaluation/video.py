"""Record frames during an evaluation and write them as MP4 (imageio + ffmpeg) or GIF (Pillow), plus PNG sheets."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import torch

from .render import CameraSpec, EnvRenderer, tile


class VideoRecorder:
    """Frames of the first ``grid * grid`` worlds of every task (every task with worlds, ``task_ids``): every
    ``every``-th step of an episode (steps 0, every, 2 * every, ...), ``frames`` of them.

    ``capture(t, finished)`` renders the state at step ``t`` into frame ``t // every`` where it is one of those
    steps (on the env's device, no host sync); a world whose first episode has ended (``finished``, bool over the
    env's worlds; envs of one simulator, e.g. Parkour) keeps its last frame of that episode, so that a video shows
    the first episode only;
    ``videos()`` returns uint8 ``[num_tasks, frames, H * grid, W * grid, 3]`` on the CPU.
    """

    def __init__(self, env: Any, frames: int, width: int, height: int, *, grid: int = 1,
                 camera: CameraSpec | None = None, every: int = 1) -> None:
        if frames < 1:
            raise ValueError(f"frames must be >= 1, got {frames}")
        if every < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        self.frames, self.grid, self.every = int(frames), int(grid), int(every)
        self.renderer = EnvRenderer(env, width, height, worlds_per_task=grid * grid, camera=camera)
        self.num_tasks = self.renderer.num_tasks
        self.task_ids = self.renderer.task_ids  # the rendered tasks, in the order of the videos
        device = self.renderer.device
        self._buffer = torch.zeros(self.frames, self.num_tasks, grid * grid, height, width, 3, dtype=torch.uint8,
                                   device=device)
        self.captured = 0

    def capture(self, t: int, finished: torch.Tensor | None = None) -> None:
        k, off = divmod(t, self.every)
        if off or k >= self.frames:
            return
        frame = self.renderer.render()
        index = self.renderer.world_index
        if finished is not None and index is not None and k > 0:
            hold = finished.to(frame.device)[index]  # [num_tasks, worlds_per_task]
            frame = torch.where(hold[..., None, None, None], self._buffer[k - 1], frame)
        self._buffer[k] = frame
        self.captured = max(self.captured, k + 1)

    def videos(self) -> torch.Tensor:
        frames = tile(self._buffer[: self.captured], self.grid)  # [T, K, H, W, 3]
        return frames.transpose(0, 1).cpu()


def mp4_available() -> bool:
    """True when imageio can write MP4 through ffmpeg (the ``imageio-ffmpeg`` package)."""
    return importlib.util.find_spec("imageio") is not None and importlib.util.find_spec("imageio_ffmpeg") is not None


def progress_bar(frames: np.ndarray, height: int = 2) -> np.ndarray:
    """A copy of ``[T, H, W, 3]`` frames with the episode progress ``(t + 1) / T`` as a bar along the bottom edge.

    The bar's shade alternates between consecutive frames, so that no two consecutive frames are identical: GIF
    writers merge identical frames into one longer frame, which would change the file's frame count.
    """
    out = frames.copy()
    t_count, _, width = frames.shape[:3]
    for t in range(t_count):
        filled = max(1, round(width * (t + 1) / t_count))
        out[t, -height:, :filled] = (30, 30, 30) if t % 2 == 0 else (70, 70, 70)
    return out


def write_video(stem: Path, frames: torch.Tensor | np.ndarray, fps: int) -> Path:
    """Write uint8 ``[T, H, W, 3]`` frames, with a :func:`progress_bar`, to ``<stem>.mp4`` (imageio with ffmpeg,
    H.264) when available, else to ``<stem>.gif`` (Pillow). Returns the written path."""
    array = np.ascontiguousarray(torch.as_tensor(frames).cpu().numpy().astype(np.uint8))
    if array.ndim != 4 or array.shape[-1] != 3 or array.shape[0] < 1:
        raise ValueError(f"frames must be uint8 [T, H, W, 3] with T >= 1, got shape {array.shape}")
    array = progress_bar(array)
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    if mp4_available():
        import imageio.v2 as imageio

        # H.264 in yuv420p needs even sides: pad by one row/column of the edge pixels where needed
        h, w = array.shape[1:3]
        array = np.pad(array, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")
        path = stem.with_suffix(".mp4")
        imageio.mimwrite(path, list(array), fps=fps, codec="libx264", macro_block_size=1,
                         ffmpeg_log_level="error", output_params=["-pix_fmt", "yuv420p"])
        return path
    from PIL import Image

    path = stem.with_suffix(".gif")
    images = [Image.fromarray(frame) for frame in array]
    images[0].save(path, save_all=True, append_images=images[1:], duration=max(1, round(1000 / fps)), loop=0)
    return path


def read_video(path: Path) -> np.ndarray:
    """Frames ``[T, H, W, 3]`` of a video written by :func:`write_video` (GIF with Pillow, MP4 with imageio)."""
    path = Path(path)
    if path.suffix == ".mp4":
        import imageio.v2 as imageio

        return np.stack(list(imageio.mimread(path, memtest=False)))[..., :3]
    from PIL import Image, ImageSequence

    with Image.open(path) as image:
        return np.stack([np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(image)])


def contact_sheet(frames: Sequence[np.ndarray], labels: Sequence[str], columns: int | None = None) -> np.ndarray:
    """One image of ``frames`` (uint8 ``[H, W, 3]`` each, same size) side by side (``columns`` per row), each with
    its label in a strip above it."""
    from PIL import Image, ImageDraw

    if not frames or len(frames) != len(labels):
        raise ValueError(f"need one label per frame, got {len(frames)} frames and {len(labels)} labels")
    h, w = frames[0].shape[:2]
    columns = columns or len(frames)
    rows = math.ceil(len(frames) / columns)
    strip = 16
    sheet = Image.new("RGB", (columns * w, rows * (h + strip)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for i, (frame, label) in enumerate(zip(frames, labels)):
        x, y = (i % columns) * w, (i // columns) * (h + strip)
        sheet.paste(Image.fromarray(np.asarray(frame, dtype=np.uint8)), (x, y + strip))
        draw.text((x + 4, y + 2), _fit(draw, str(label), w - 8), fill=(0, 0, 0))
    return np.asarray(sheet)


def _fit(draw, text: str, width: float) -> str:
    """``text``, shortened with ".." at the end where it is wider than ``width`` pixels (a label stays in its cell)."""
    if draw.textlength(text) <= width:
        return text
    while text and draw.textlength(text + "..") > width:
        text = text[:-1]
    return text + ".."


def write_png(path: Path, image: np.ndarray) -> Path:
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(path)
    return path


__all__ = ["VideoRecorder", "contact_sheet", "mp4_available", "progress_bar", "read_video", "write_png", "write_video"]
