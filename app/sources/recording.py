"""Raw recordings: a folder of sensor data that the pipeline replays as if it came from the rig.

A format any user can produce with other tools (ffmpeg, a camera's SDK, a sound recorder, a spreadsheet); also
documented in ``recordings/FORMAT.md``. One folder per recording::

    NAME/
      rig.yaml          required  the rig calibration (app.config: stereo + microphones sections)
      left.avi          required  the left camera: a video file OpenCV reads (.avi, .mp4, .mkv; MJPG by default),
      right.avi                   or a folder left/ of images (.png, .jpg, .bmp), sorted by name, one per frame
      frames.csv        required  header "frame,left_stamp_s,right_stamp_s"; row k: frame k (0, 1, ...) and the
                                  capture times of its two images, seconds, non-decreasing
      audio.wav         required  one multichannel WAV: PCM 16/24/32-bit integer or 32-bit float; sample 0 was
                                  captured at audio_start_s, sample i at audio_start_s + i / samplerate
      recording.json    optional  {"format": "avhear-raw-recording", "version": 1, "audio_start_s": 0.0,
                                  "channels": {"left": 0, "right": 1}, "fps": 30.0, "source": {...}}
                                  defaults: audio_start_s 0, channels left 0 / right 1, fps from frames.csv;
                                  "camera": "mono" for one camera (left alone, no right)
      truth.csv         optional  ground truth per frame and person: frame,time_s,person,name,x_m,y_m,z_m,
                                  visible,speaking,sounding,itd_s,box_x,box_y,box_w,box_h (scene frame, metres)
      events.csv        optional  the sound events: person,name,kind,start_s,end_s,label (seconds, same clock)

All stamps are seconds on one clock (the simulator: from 0; a live capture: ``time.monotonic()``).

:func:`write_recording` writes a source (the simulator) into a folder; :class:`RecordingWriter` writes frames and
blocks as they come (for ``avhear record``); :func:`open_recording` validates a folder and returns a
:class:`Recording`, a :class:`app.sources.replay.ReplayStream` that yields the same stream of timestamped frames and audio
blocks as the simulator did, at real speed or as fast as possible. Missing, truncated or corrupt files raise
:class:`RecordingError` naming the file, what is wrong and what to do.
"""
from __future__ import annotations

import csv
import json
import logging
import math
import shutil
import struct
import threading
import wave
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from app.config import RigConfig, load_rig, save_rig
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.sources.replay import ReplayStream
from avcore.depth import as_depth_m, depth_millimetres
from avcore.evaluation import FrameTruth

__all__ = ["RecordingError", "RecordingWriter", "Recording", "open_recording", "write_recording", "FORMAT"]

log = logging.getLogger(__name__)

FORMAT = "avhear-raw-recording"
VERSION = 1
FRAMES_HEADER = ["frame", "left_stamp_s", "right_stamp_s"]
TRUTH_HEADER = ["frame", "time_s", "person", "name", "x_m", "y_m", "z_m", "visible", "speaking", "sounding",
                "itd_s", "box_x", "box_y", "box_w", "box_h"]
EVENTS_HEADER = ["person", "name", "kind", "start_s", "end_s", "label"]
VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")


class RecordingError(UserError):
    """A recording folder or one of its files is missing, truncated or corrupt; the message says what to do."""


# ---------------------------------------------------------------------------------------------------------------
# writing


class RecordingWriter:
    """Writes a recording folder incrementally: :meth:`add_frame`, :meth:`add_audio`, then :meth:`close` (or use
    it as a context manager).

    folder : created if needed; refused if it already holds a recording unless ``overwrite``.
    rig : the rig calibration written to rig.yaml; fps : nominal frame rate (for the video container);
    video : "avi" (MJPG, ``jpeg_quality``) or "png" (lossless image sequences, larger);
    channels : which WAV channels are the left and right microphones; meta : stored under "source" in
    recording.json.
    """

    def __init__(self, folder: str | Path, *, rig: RigConfig, fps: float, samplerate_hz: int, n_channels: int,
                 video: str = "avi", jpeg_quality: int = 95, channels: dict[str, int] | None = None,
                 meta: dict[str, Any] | None = None, overwrite: bool = False) -> None:
        self.folder = Path(folder)
        if video not in ("avi", "png"):
            raise ValueError(f"video must be 'avi' (MJPG) or 'png' (image sequences), got {video!r}")
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number of frames per second, got {fps!r}")
        if n_channels < 1:
            raise ValueError(f"n_channels must be at least 1, got {n_channels!r}")
        if rig.stereo is None:
            raise ValueError("rig has no stereo section; a recording needs the cameras' calibration")
        if (self.folder / "frames.csv").exists() and not overwrite:
            raise RecordingError(f"{self.folder} already holds a recording (frames.csv); choose another folder or "
                                 "pass overwrite (--force) to replace it")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecordingError(f"{self.folder}: cannot create the recording folder ({exc.strerror})") from None
        for stale in ("truth.csv", "events.csv", "left.avi", "right.avi"):
            (self.folder / stale).unlink(missing_ok=True)
        shutil.rmtree(self.folder / "depth", ignore_errors=True)  # else a stereo recording would read as RGB-D
        self.rig_config = rig
        self.fps = float(fps)
        self.samplerate_hz = int(samplerate_hz)
        self.n_channels = int(n_channels)
        self.video = video
        self.jpeg_quality = int(jpeg_quality)
        self.channels = dict(channels or {"left": 0, "right": 1})
        self.camera = "stereo"  # or "mono", from the frames written
        self.meta = dict(meta or {})
        save_rig(self.folder / "rig.yaml", rig)
        self._frames_file = open(self.folder / "frames.csv", "w", newline="", encoding="utf-8")
        self._frames = csv.writer(self._frames_file)
        self._frames.writerow(FRAMES_HEADER)
        self._truth_file = None
        self._truth: Any = None
        self._writers: dict[str, cv2.VideoWriter] = {}
        self._wav = wave.open(str(self.folder / "audio.wav"), "wb")
        self._wav.setnchannels(self.n_channels)
        self._wav.setsampwidth(2)
        self._wav.setframerate(self.samplerate_hz)
        self.n_frames = 0
        self.n_samples = 0
        self.audio_start_s: float | None = None
        self._closed = False

    def add_frame(self, frame: StereoFrame, truth: FrameTruth | None = None) -> None:
        """Append one frame (its images, or an RGB-D camera's colour and depth; its stamps) and its ground truth
        when known."""
        if frame.index != self.n_frames:
            log.debug("frame %d written as frame %d (frames are renumbered in order)", frame.index, self.n_frames)
        w, h = self.rig_config.stereo.image_size  # type: ignore[union-attr]
        sides = [("left", frame.left)] if frame.right is None else [("left", frame.left), ("right", frame.right)]
        if frame.right is None and frame.depth_m is None:
            self.camera = "mono"  # one camera: its images alone (recording.json says so)
        for side, img in sides:
            if not isinstance(img, np.ndarray) or img.shape != (h, w, 3) or img.dtype != np.uint8:
                got = f"{img.dtype} {img.shape}" if isinstance(img, np.ndarray) else type(img).__name__
                raise ValueError(f"{side} image must be ({h}, {w}, 3) uint8 as the rig says, got {got}")
            if self.video == "png":
                self._write_png(side, img)
            else:
                writer = self._writers.get(side)
                if writer is None:
                    writer = cv2.VideoWriter(str(self.folder / f"{side}.avi"), cv2.VideoWriter_fourcc(*"MJPG"),
                                             self.fps, (w, h))
                    writer.set(cv2.VIDEOWRITER_PROP_QUALITY, self.jpeg_quality)
                    if not writer.isOpened():
                        raise RecordingError(f"{self.folder / side}.avi: OpenCV cannot write MJPG video here; "
                                             "use --video png")
                    self._writers[side] = writer
                writer.write(img)
        if frame.depth_m is not None:  # an RGB-D camera: 16-bit PNG millimetres, lossless (recordings/FORMAT.md)
            if frame.depth_m.shape != (h, w):
                raise ValueError(f"the depth image must be ({h}, {w}) as the rig says, got {frame.depth_m.shape}")
            self._write_png("depth", depth_millimetres(frame.depth_m))
        self._frames.writerow([self.n_frames, repr(float(frame.stamp_s)), repr(float(frame.right_stamp_s))])
        self._frames_file.flush()  # each frame's row on disk as it comes, not a buffer's worth later: progress shows
        if truth is not None:
            self._write_truth(self.n_frames, frame.stamp_s, truth)
        self.n_frames += 1

    def _write_png(self, side: str, img: np.ndarray) -> None:
        d = self.folder / side
        d.mkdir(exist_ok=True)
        if not cv2.imwrite(str(d / f"{self.n_frames:06d}.png"), img):
            raise RecordingError(f"{d}: cannot write frame {self.n_frames} (disk full or not writable?)")

    def _write_truth(self, k: int, stamp_s: float, truth: FrameTruth) -> None:
        if self._truth is None:
            self._truth_file = open(self.folder / "truth.csv", "w", newline="", encoding="utf-8")
            self._truth = csv.writer(self._truth_file)
            self._truth.writerow(TRUTH_HEADER)
        names = truth.names or tuple(f"person{i}" for i in range(truth.positions_m.shape[0]))
        for i in range(truth.positions_m.shape[0]):
            x, y, z = (repr(float(v)) for v in truth.positions_m[i])
            box = [repr(float(v)) for v in truth.boxes_left[i]]
            self._truth.writerow([k, repr(float(stamp_s)), i, names[i], x, y, z, int(truth.visible[i]),
                                  int(truth.speaking[i]), int(truth.sounding[i]), repr(float(truth.itds_s[i])), *box])

    def add_audio(self, block: AudioBlock) -> None:
        """Append one audio block; blocks must follow each other without a gap (``first_sample``)."""
        samples = np.asarray(block.samples)
        if samples.ndim != 2 or samples.shape[1] != self.n_channels:
            raise ValueError(f"audio block must be (n, {self.n_channels}) samples, got shape {samples.shape}")
        if block.samplerate_hz != self.samplerate_hz:
            raise ValueError(f"audio block at {block.samplerate_hz} Hz, the recording is at {self.samplerate_hz} Hz")
        if self.audio_start_s is None:  # the WAV's sample 0 is this block's first (a stream joined late: not 0)
            self.audio_start_s = block.stamp_s
            self._first_sample = block.first_sample
        elif block.first_sample != self._first_sample + self.n_samples:
            raise ValueError(f"audio block starts at sample {block.first_sample}, expected "
                             f"{self._first_sample + self.n_samples}: the WAV cannot hold a gap")
        if samples.dtype == np.int16:
            pcm = samples
        else:
            pcm = np.clip(np.round(samples.astype(np.float64) * 32768.0), -32768, 32767).astype("<i2")
        self._wav.writeframes(np.ascontiguousarray(pcm, dtype="<i2").tobytes())
        self.n_samples += samples.shape[0]

    def write_events(self, rows: list[tuple[int, str, str, float, float, str]]) -> None:
        """Write events.csv: (person, name, kind, start_s, end_s, label) per sound event, stamps on this clock."""
        with open(self.folder / "events.csv", "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(EVENTS_HEADER)
            for person, name, kind, start, end, label in rows:
                w.writerow([person, name, kind, repr(float(start)), repr(float(end)), label])

    def close(self) -> None:
        """Finish every file (WAV header, video index, recording.json); idempotent."""
        if self._closed:
            return
        self._closed = True
        for writer in self._writers.values():
            writer.release()
        self._wav.close()
        self._frames_file.close()
        if self._truth_file is not None:
            self._truth_file.close()
        info = {"format": FORMAT, "version": VERSION, "fps": self.fps, "samplerate_hz": self.samplerate_hz,
                "n_channels": self.n_channels, "audio_start_s": float(self.audio_start_s or 0.0),
                "channels": self.channels, "video": self.video, "n_frames": self.n_frames,
                "n_samples": self.n_samples, "source": self.meta}
        if self.camera == "mono":
            info["camera"] = "mono"
        (self.folder / "recording.json").write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def write_recording(folder: str | Path, source: ReplayStream, *, video: str = "avi", overwrite: bool = False,
                    progress: Callable[[int, int], None] | None = None,
                    stop: threading.Event | None = None) -> Path:
    """Write everything ``source`` streams (as fast as possible) into a recording folder; returns the folder.

    progress : called as ``progress(frames_written, n_frames)`` after every frame.
    stop : when set, writing ends after the current item (a complete frame or audio block) and the folder is
        closed as a whole recording of what was written, its events cut at its last frame.
    """
    array = getattr(source, "array", None)
    array = array if array is not None and array.n_pairs > 1 else None
    rig = RigConfig(stereo=source.stereo, microphones=source.mics, array=array)
    first = array.pairs[0] if array is not None else (0, 1)  # type: ignore[index]
    channels = ({"left": array.channels[first[0]], "right": array.channels[first[1]]}  # type: ignore[index]
                if array is not None else None)
    meta = dict(getattr(source, "meta", {}) or {})
    with RecordingWriter(folder, rig=rig, fps=source.fps, samplerate_hz=source.samplerate_hz,
                         n_channels=source.n_channels, video=video, meta=meta, overwrite=overwrite,
                         channels=channels) as writer:
        end, last = float("inf"), -float("inf")
        for item in source.stream(realtime=False):
            if stop is not None and stop.is_set():
                end = last  # the recording ends with its last frame: so do its events
                break
            if isinstance(item, StereoFrame):
                writer.add_frame(item, source.truth(item.index))
                last = item.stamp_s
                if progress:
                    progress(writer.n_frames, source.n_frames)
            else:
                writer.add_audio(item)
        scenario = getattr(source, "scenario", None)
        if scenario is not None:
            writer.write_events([(e.actor, scenario.actors[e.actor].name, e.kind, e.start_s, min(e.end_s, end),
                                  e.label) for e in scenario.events if e.start_s < end])
    return Path(folder)


# ---------------------------------------------------------------------------------------------------------------
# reading


def _wav_layout(path: Path) -> tuple[int, int, str, int, int]:
    """Parse a WAV header: (samplerate, channels, numpy dtype, data offset, frames). Raises RecordingError."""
    try:
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(12)
            if len(head) < 12 or head[:4] not in (b"RIFF", b"RF64") or head[8:12] != b"WAVE":
                raise RecordingError(f"{path}: not a WAV file (no RIFF/WAVE header); export the audio as WAV")
            fmt = None
            while True:
                chunk = f.read(8)
                if len(chunk) < 8:
                    raise RecordingError(f"{path}: no audio data chunk found (the file is truncated or corrupt); "
                                         "re-export the audio as WAV")
                cid, clen = chunk[:4], struct.unpack("<I", chunk[4:])[0]
                if cid == b"fmt ":
                    body = f.read(clen)
                    if len(body) < 16:
                        raise RecordingError(f"{path}: the format chunk is truncated; re-export the audio as WAV")
                    tag, channels, rate, _, align, bits = struct.unpack("<HHIIHH", body[:16])
                    if tag == 0xFFFE and len(body) >= 26:  # WAVE_FORMAT_EXTENSIBLE: the sub-format's first two bytes
                        tag = struct.unpack("<H", body[24:26])[0]
                    fmt = (tag, channels, rate, align, bits)
                    if clen % 2:
                        f.read(1)
                elif cid == b"data":
                    if fmt is None:
                        raise RecordingError(f"{path}: the data chunk comes before the format chunk; re-export "
                                             "the audio as WAV")
                    offset = f.tell()
                    break
                else:
                    f.seek(clen + (clen % 2), 1)
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read the audio file ({exc.strerror})") from None
    tag, channels, rate, align, bits = fmt
    dtypes = {(1, 16): "<i2", (1, 32): "<i4", (3, 32): "<f4", (1, 24): "i24"}
    if (tag, bits) not in dtypes or channels < 1 or rate < 1 or align != channels * bits // 8:
        raise RecordingError(f"{path}: unsupported WAV encoding (format tag {tag}, {bits} bits, {channels} "
                             "channels); use PCM 16/24/32-bit integers or 32-bit float")
    available = size - offset
    declared = clen
    if declared == 0xFFFFFFFF:  # a streaming writer that never knew the length: take what is there
        declared = available - available % align
    elif declared > available:
        raise RecordingError(
            f"{path} is truncated: its header announces {declared} bytes of samples but only {available} "
            "are in the file. Re-export it, or repair the header (e.g. `sox --ignore-length in.wav out.wav`) "
            "to keep what is there")
    elif declared == 0 and available > 0:
        raise RecordingError(f"{path}: the header announces no samples but the file holds {available} bytes "
                             "(the recorder did not finish writing it). Repair the header, e.g. "
                             "`sox --ignore-length in.wav out.wav`")
    frames = declared // align
    return rate, channels, dtypes[(tag, bits)], offset, frames


def _csv_rows(path: Path) -> list[list[str]]:
    """Every row of a CSV file of the folder; a file that is not UTF-8 text is a :class:`RecordingError`."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.reader(f))
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{path}: not UTF-8 text (byte {exc.start}); the file is corrupt or was saved in "
                             "another encoding: save it as UTF-8") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read it ({exc.strerror})") from None


class Recording(ReplayStream):
    """A recording folder opened for replay (see the module docstring for the format); made by
    :func:`open_recording`. Its stream is the same as the source that was recorded: frames with their recorded stamps
    (and truth when the folder has it), audio blocks of ``block_size`` samples stamped from ``audio_start_s``."""

    def __init__(self, folder: str | Path, *, block_size: int = 512) -> None:
        super().__init__()
        self.folder = Path(folder)
        if self.folder.is_file():
            raise RecordingError(f"{self.folder} is a file: a recording is a folder (frames.csv, audio.wav, rig.yaml "
                                 "and the images); give the folder that holds them (recordings/FORMAT.md)")
        if not self.folder.is_dir():
            raise RecordingError(f"{self.folder}: no such recording folder; record one with `avhear simulate S2 -o "
                                 f"{self.folder}` or see recordings/FORMAT.md")
        self.block_size = int(block_size)
        self.info = self._read_info()
        rig_path = self.folder / "rig.yaml"
        if not rig_path.is_file():
            raise RecordingError(f"{rig_path}: missing; copy the rig calibration of the robot that recorded this "
                                 "(avhear calibrate stereo ... -o rig.yaml) into the folder")
        self.rig_config = load_rig(rig_path)
        if self.rig_config.stereo is None:
            raise RecordingError(f"{rig_path}: has no 'stereo' section; replay needs the cameras' calibration")
        self.stereo = self.rig_config.stereo
        # a microphone array in the rig file: every pair of it (its first pair stands for the pair)
        self.array = self.rig_config.array
        self.mics = self.rig_config.microphones if self.array is None else self.array.pair(0)
        self.frame_stamps_s, self.right_stamps_s = self._read_frames_csv()
        fps = self.info.get("fps")
        if fps is None:
            gaps = np.diff(self.frame_stamps_s)
            fps = 1.0 / float(np.median(gaps)) if gaps.size and np.median(gaps) > 0 else 30.0
        self.fps = float(fps)
        # an RGB-D camera's recording: the colour camera as "left" and a depth/ folder of 16-bit PNG millimetres
        self.depth_files = self._depth_files()
        # one camera's recording: recording.json's "camera": "mono", and the left camera alone
        self.camera = str(self.info.get("camera", "stereo"))
        if self.camera not in ("stereo", "mono"):
            raise RecordingError(f"{self.folder / 'recording.json'}: 'camera' must be \"stereo\" or \"mono\", got "
                                 f"{self.camera!r}")
        sides = ("left",) if self.depth_files is not None or self.camera == "mono" else ("left", "right")
        self._video = {side: self._find_video(side) for side in sides}
        wav = self.folder / "audio.wav"
        if not wav.is_file():
            raise RecordingError(f"{wav}: missing; the recording needs the microphones' multichannel WAV")
        self.samplerate_hz, self.n_channels, dtype, offset, n = _wav_layout(wav)
        self.n_samples = int(n)
        self._audio_dtype = dtype
        if dtype == "i24":
            raw = np.fromfile(wav, dtype=np.uint8, count=n * self.n_channels * 3, offset=offset).reshape(-1, 3)
            ints = (raw[:, 0].astype(np.int32) | (raw[:, 1].astype(np.int32) << 8)
                    | (raw[:, 2].astype(np.int8).astype(np.int32) << 16))
            self._audio = (ints.reshape(n, self.n_channels).astype(np.float32) / np.float32(2**23))
        elif n == 0:
            self._audio = np.zeros((0, self.n_channels), dtype=dtype)
        else:
            self._audio = np.memmap(wav, dtype=dtype, mode="r", offset=offset, shape=(n, self.n_channels))
        self.audio_start_s = float(self.info.get("audio_start_s", 0.0))
        channels = self.info.get("channels", {"left": 0, "right": 1})
        if not all(0 <= int(channels.get(k, -1)) < self.n_channels for k in ("left", "right")):
            raise RecordingError(f"{self.folder / 'recording.json'}: 'channels' {channels} does not name a left and "
                                 f"a right channel among the {self.n_channels} of audio.wav")
        self.channels = {k: int(v) for k, v in channels.items()}
        self._truth = self._read_truth()
        self.events = self._read_events()
        self.meta = dict(self.info.get("source", {}))
        self._caps: dict[str, Any] = {}
        self._next = 0
        self._check_videos()

    # -------------------------------------------------------------- files
    def _read_info(self) -> dict[str, Any]:
        path = self.folder / "recording.json"
        if not path.is_file():
            return {}
        try:
            info = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise RecordingError(f"{path}: not valid JSON ({exc}); fix it or delete it (every key is optional)") \
                from None
        if not isinstance(info, dict):
            raise RecordingError(f"{path}: must hold a JSON object; fix it or delete it (every key is optional)")
        for key in ("fps", "audio_start_s"):
            if key in info and (isinstance(info[key], bool) or not isinstance(info[key], (int, float))
                                or not math.isfinite(info[key])):
                raise RecordingError(f"{path}: key '{key}' must be a finite number, got {info[key]!r}")
        if "channels" in info and not isinstance(info["channels"], dict):
            raise RecordingError(f"{path}: key 'channels' must be an object like {{\"left\": 0, \"right\": 1}}")
        return info

    def _read_frames_csv(self) -> tuple[np.ndarray, np.ndarray]:
        path = self.folder / "frames.csv"
        if not path.is_file():
            raise RecordingError(f"{path}: missing; it lists each frame's capture times "
                                 f"({','.join(FRAMES_HEADER)}, one row per frame)")
        rows = _csv_rows(path)
        if not rows or [c.strip() for c in rows[0]] != FRAMES_HEADER:
            raise RecordingError(f"{path}: the first line must be the header {','.join(FRAMES_HEADER)}, got "
                                 f"{','.join(rows[0]) if rows else 'an empty file'}")
        left, right = [], []
        for line, row in enumerate(rows[1:], start=2):
            if not row:
                continue
            try:
                if len(row) != 3:
                    raise ValueError(f"{len(row)} fields instead of 3")
                k, tl, tr = int(row[0]), float(row[1]), float(row[2])
            except ValueError as exc:
                raise RecordingError(f"{path}, line {line}: cannot read {row!r} ({exc}); each row is "
                                     "frame,left_stamp_s,right_stamp_s") from None
            if k != len(left):
                raise RecordingError(f"{path}, line {line}: frame {k} where frame {len(left)} was expected; frames "
                                     "must be numbered 0, 1, 2, ... in order")
            if not (math.isfinite(tl) and math.isfinite(tr)):
                raise RecordingError(f"{path}, line {line}: stamps must be finite seconds, got {row!r}")
            if left and (tl < left[-1] or tr < right[-1]):
                raise RecordingError(f"{path}, line {line}: stamps go back in time; they must not decrease")
            left.append(tl)
            right.append(tr)
        if not left:
            raise RecordingError(f"{path}: lists no frame; a recording needs at least one")
        return np.array(left), np.array(right)

    def _depth_files(self) -> list[Path] | None:
        d = self.folder / "depth"
        if not d.is_dir():
            return None
        files = sorted(p for p in d.iterdir() if p.suffix.lower() == ".png")
        if len(files) < self.n_frames:
            raise RecordingError(f"{d}: holds {len(files)} depth images but frames.csv lists {self.n_frames} frames; "
                                 "the sequence is truncated: add the missing images or cut frames.csv")
        return files

    def _find_video(self, side: str) -> tuple[str, Any]:
        d = self.folder / side
        if d.is_dir():
            files = sorted(p for p in d.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if len(files) < self.n_frames:
                raise RecordingError(f"{d}: holds {len(files)} images but frames.csv lists {self.n_frames} frames; "
                                     "the sequence is truncated: add the missing images or cut frames.csv")
            return "images", files
        for suffix in VIDEO_SUFFIXES:
            p = self.folder / f"{side}{suffix}"
            if p.is_file():
                return "video", p
        raise RecordingError(f"{self.folder}: no {side} camera: expected {side}.avi (or .mp4/.mkv/.mov) or a folder "
                             f"{side}/ of images")

    def _check_videos(self) -> None:
        w, h = self.stereo.image_size
        for side, (kind, what) in self._video.items():
            if kind == "video":
                cap = cv2.VideoCapture(str(what))
                ok = cap.isOpened()
                count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if ok else 0
                ok, img = cap.read() if ok else (False, None)
                cap.release()
                if not ok:
                    raise RecordingError(f"{what}: OpenCV cannot decode this video (corrupt, empty or an unknown "
                                         "codec); re-encode it, e.g. `ffmpeg -i IN -c:v mjpeg OUT.avi`, or export "
                                         "the frames as images into a folder")
                if 0 < count < self.n_frames:
                    raise RecordingError(f"{what}: holds {count} frames but frames.csv lists {self.n_frames}; the "
                                         "video is truncated: cut frames.csv to the frames present")
            else:
                img = cv2.imread(str(what[0]), cv2.IMREAD_COLOR)
                if img is None:
                    raise RecordingError(f"{what[0]}: cannot be decoded as an image; replace it")
            if img.shape[:2] != (h, w):
                raise RecordingError(f"{self.folder}: the {side} images are {img.shape[1]}x{img.shape[0]} but "
                                     f"rig.yaml says {w}x{h}; use the rig calibration of these cameras")

    def _read_truth(self) -> list[FrameTruth] | None:
        path = self.folder / "truth.csv"
        if not path.is_file():
            return None
        rows = _csv_rows(path)
        if not rows or rows[0] != TRUTH_HEADER:
            raise RecordingError(f"{path}: the first line must be the header {','.join(TRUTH_HEADER)}; fix or "
                                 "delete the file (truth is optional)")
        per_frame: dict[int, list[list[str]]] = {}
        for line, row in enumerate(rows[1:], start=2):
            if len(row) != len(TRUTH_HEADER):
                raise RecordingError(f"{path}, line {line}: {len(row)} fields instead of {len(TRUTH_HEADER)} (the "
                                     "file is truncated or corrupt); fix or delete it (truth is optional)")
            per_frame.setdefault(int(row[0]), []).append(row)
        out = []
        for k in range(self.n_frames):
            rows_k = sorted(per_frame.get(k, []), key=lambda r: int(r[2]))
            if not rows_k:
                raise RecordingError(f"{path}: no truth for frame {k}; the file is truncated; fix or delete it")
            try:
                num = np.array([[float(r[c]) for c in (4, 5, 6, 10, 11, 12, 13, 14)] for r in rows_k])
                flags = np.array([[int(r[c]) for c in (7, 8, 9)] for r in rows_k], dtype=bool)
                t = float(rows_k[0][1])
            except ValueError as exc:
                raise RecordingError(f"{path}: frame {k}: {exc}; fix or delete the file (truth is optional)") \
                    from None
            out.append(FrameTruth(t, num[:, :3], flags[:, 0], flags[:, 1], flags[:, 2], num[:, 4:8], num[:, 3],
                                  tuple(r[3] for r in rows_k)))
        return out

    def _read_events(self) -> list[dict[str, Any]]:
        path = self.folder / "events.csv"
        if not path.is_file():
            return []
        rows = _csv_rows(path)
        if not rows or rows[0] != EVENTS_HEADER:
            raise RecordingError(f"{path}: the header must be {','.join(EVENTS_HEADER)}; fix or delete it")
        try:
            return [{"person": int(r[0]), "name": r[1], "kind": r[2], "start_s": float(r[3]), "end_s": float(r[4]),
                     "label": r[5]} for r in rows[1:] if r]
        except (IndexError, ValueError) as exc:
            raise RecordingError(f"{path}: {exc}; fix or delete the file (events are optional)") from None

    # -------------------------------------------------------------- ReplayStream
    def _reset(self) -> None:
        for cap in self._caps.values():
            cap.release()
        self._caps = {}
        self._next = 0

    def _depth(self, k: int, colour: np.ndarray) -> np.ndarray | None:
        if self.depth_files is None:
            return None
        img = cv2.imread(str(self.depth_files[k]), cv2.IMREAD_UNCHANGED)
        if img is None or img.dtype != np.uint16 or img.shape != colour.shape[:2]:
            raise RecordingError(f"{self.depth_files[k]}: not a 16-bit depth image of the colour image's size "
                                 f"(frame {k}); replace it")
        return as_depth_m(img)

    def _images(self, k: int) -> tuple[np.ndarray, np.ndarray | None]:
        out = []
        for side in self._video:
            kind, what = self._video[side]
            if kind == "images":
                img = cv2.imread(str(what[k]), cv2.IMREAD_COLOR)
                if img is None:
                    raise RecordingError(f"{what[k]}: cannot be decoded as an image (frame {k}); replace it")
            else:
                cap = self._caps.get(side)
                if cap is None:
                    cap = self._caps[side] = cv2.VideoCapture(str(what))
                for _ in range(self._next, k):  # frames skipped by a late real-time consumer
                    cap.grab()
                ok, img = cap.read()
                if not ok:
                    raise RecordingError(f"{what}: frame {k} of the {self.n_frames} in frames.csv cannot be decoded; "
                                         "the video is truncated or corrupt: re-encode it (e.g. `ffmpeg -i IN -c:v "
                                         "mjpeg OUT.avi`) or cut frames.csv to the frames present")
            out.append(img)
        self._next = k + 1
        return (out[0], out[1]) if len(out) == 2 else (out[0], None)

    def _samples(self, a: int, b: int) -> np.ndarray:
        x = np.asarray(self._audio[a:b])
        if self._audio_dtype == "<i2":
            return x.astype(np.float32) / np.float32(32768.0)
        if self._audio_dtype == "<i4":
            return (x.astype(np.float64) / 2**31).astype(np.float32)
        return x.astype(np.float32)

    def truth(self, k: int) -> FrameTruth | None:
        return None if self._truth is None else self._truth[k]

    @property
    def has_truth(self) -> bool:
        return self._truth is not None

    def close(self) -> None:
        """Release the video readers (idempotent)."""
        self._reset()

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_recording(folder: str | Path, *, block_size: int = 512) -> Recording:
    """Validate a recording folder and open it for replay; raises :class:`RecordingError` with what to do."""
    return Recording(folder, block_size=block_size)
