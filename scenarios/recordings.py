"""Recordings of pedestrians in the ETH/UCY four-column format, read into tracks.

A file holds one row per person and frame: ``frame id x y`` (whitespace-separated, or commas; metres),
the format of the ETH (Pellegrini et al., 2009) and UCY (Lerner, Chrysanthou, Lischinski,
"Crowds by Example", 2007) recordings as the prediction literature shares them. Frame ids
count the frames of the recording's video, 10 apart between annotated rows; what a frame
lasts follows the video (:func:`seconds_per_frame`): the common ``biwi_eth.txt`` was filmed
at 15 fps (its rows 0.667 s apart, a pitfall reported in several projects' issues), the UCY
files and ``biwi_hotel.txt`` at 25 fps (rows 0.4 s apart).

The UCY recordings ``crowds_zara01``, ``crowds_zara02`` and ``students003`` ship with the
package (``scenarios/recordings/*.txt.gz``, as kept by ``StanfordASL/Trajectron-plus-plus``,
``experiments/pedestrians/raw/raw/all_data/``), used with credit to their authors
(docs/pedestrians.md).
"""
from __future__ import annotations

import gzip
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .loader import LARGEST

__all__ = ["Recording", "RecordingError", "read_recording", "recording_name", "seconds_per_frame", "SHIPPED",
           "shipped_recording", "MAX_GAP_ROWS", "WALKING_SPEEDS_MPS"]

RECORDINGS_DIR = Path(__file__).parent / "recordings"
SHIPPED = ("crowds_zara01", "crowds_zara02", "students003")
"""The recordings that ship with the package, by name."""
WALKING_SPEEDS_MPS = (0.3, 3.0)
"""Median walking speeds (:attr:`Recording.walking_speed_mps`) outside these make import-tracks say
that the frame time may be wrong (a recording's frame time is not in the file)."""
MAX_GAP_ROWS = 3
"""A person's rows further apart than this many of the recording's row steps (the median time
between a person's rows: 0.4 s in the UCY files, 0.667 s in `biwi_eth`) split the track in two,
three or more rows missing: the person is out of the recording in between, not walking a straight
line. (Until 2026-12-01 a fixed 1.2 s, the same for rows 0.4 s apart: a recording with rows 0.667 s
apart split at one missing row, and one with rows over 1.2 s apart had every track split into
single rows and was refused.)"""


class RecordingError(ValueError):
    """A recording that cannot be read; the message is one line naming the file and row."""


@dataclass(frozen=True)
class Recording:
    """A recording's tracks: ``tracks[k]`` is a ``(n, 3)`` array of ``(t_s, x_m, y_m)`` rows,
    times increasing, of one person (split where rows are missing, :data:`MAX_GAP_ROWS`).
    ``people``: the ids in the file; ``lone_rows``: rows left out because no other row of their
    person is within :data:`MAX_GAP_ROWS` row steps (a person with one row: no track to follow)."""

    name: str
    seconds_per_frame: float
    tracks: tuple[np.ndarray, ...]
    people: int = 0
    lone_rows: int = 0

    @property
    def start_s(self) -> float:
        return min(float(tr[0, 0]) for tr in self.tracks)

    @property
    def end_s(self) -> float:
        return max(float(tr[-1, 0]) for tr in self.tracks)

    @property
    def walking_speed_mps(self) -> float:
        """The median over the tracks of each one's median speed between rows: 0.65 to 1.5 m/s in
        the ETH/UCY files, read at their frame times (25 times that with seconds read as frames)."""
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return float(np.median([np.median(np.hypot(*np.diff(tr[:, 1:], axis=0).T) / np.diff(tr[:, 0]))
                                    for tr in self.tracks]))

    def positions_at(self, t_s: float) -> np.ndarray:
        """Where everyone in the scene at ``t_s`` is, ``(m, 2)`` (linear between rows)."""
        out = [(np.interp(t_s, tr[:, 0], tr[:, 1]), np.interp(t_s, tr[:, 0], tr[:, 2]))
               for tr in self.tracks if tr[0, 0] <= t_s <= tr[-1, 0]]
        return np.array(out, dtype=float).reshape(-1, 2)


def seconds_per_frame(name: str) -> float:
    """What one frame id lasts in the recording called ``name``: 1/15 s for ``biwi_eth``
    (a 15 fps video) and its parts as the trajectory-prediction repositories split it
    (``biwi_eth_train``, ``biwi_eth_val``, ``biwi_eth_test``), 1/25 s for the others (the UCY
    files, ``biwi_hotel`` and theirs). Read with the UCY files' 1/25 s, ``biwi_eth_train``'s
    rows were 0.4 s apart instead of 0.667 s: its people walked at 0.6 times their speed."""
    stem = Path(name).name.split(".")[0].lower()
    return 1.0 / 15.0 if stem == "biwi_eth" or stem.startswith("biwi_eth_") else 1.0 / 25.0


def _text(path: Path) -> str:
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as exc:
            raise RecordingError(f"{path}: not a readable gzip file ({exc})") from None
    try:  # a byte-order mark first (Windows editors write one): read past it, as UTF-8 or UTF-16
        return raw.decode("utf-16" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig")
    except UnicodeDecodeError:
        raise RecordingError(f"{path}: not a text file of rows 'frame id x y'") from None


def read_recording(path, seconds_per_frame_s: float | None = None) -> Recording:
    """Read an ETH/UCY four-column file (plain or gzip) into a :class:`Recording`; a frame
    lasts ``seconds_per_frame_s`` (default: :func:`seconds_per_frame` of the file's name).
    Raises :class:`RecordingError` with one line for a file that is not of that format."""
    path = Path(path)
    spf = seconds_per_frame(path.name) if seconds_per_frame_s is None else float(seconds_per_frame_s)
    if not (math.isfinite(spf) and spf > 0):
        raise RecordingError(f"{path}: seconds per frame must be a positive number, got {seconds_per_frame_s}")
    rows, ids, names = [], {}, []
    for n, line in enumerate(_text(path).splitlines(), start=1):
        # spaces or tabs, or commas (a CSV export: 'expected four columns, got 1' until 2026-12-01)
        parts = [p.strip() for p in line.split(",")] if "," in line else line.split()
        if not parts:
            continue
        if len(parts) != 4:
            raise RecordingError(f"{path}: line {n}: expected four columns 'frame id x y', got {len(parts)}")
        try:
            values = [float(p) for p in (parts[0], parts[2], parts[3])]
        except ValueError:
            header = (" (a header line? the format has none: remove it)"
                      if not rows and not any(re.fullmatch(r"[-+.\d]", p[:1] or " ") for p in parts) else "")
            raise RecordingError(f"{path}: line {n}: not a number in {line.strip()!r}{header}") from None
        if not all(math.isfinite(v) for v in values):
            raise RecordingError(f"{path}: line {n}: numbers must be finite, got {line.strip()!r}")
        if max(abs(v) for v in values[1:]) > LARGEST:  # the scenario files' bound: a case could not be written
            raise RecordingError(f"{path}: line {n}: positions must be at most {LARGEST:g} m in magnitude, got "
                                 f"{line.strip()!r}")
        if values[0] < 0:
            raise RecordingError(f"{path}: line {n}: the frame must not be negative, got {parts[0]}")
        if not math.isfinite(values[0] * spf):
            raise RecordingError(f"{path}: line {n}: frame {parts[0]} at {spf:g} s a frame is no finite time")
        key = _person(parts[1])
        if key is None:
            raise RecordingError(f"{path}: line {n}: the id must be a finite number or a name, got {parts[1]}")
        if key not in ids:
            ids[key] = len(names)
            names.append(parts[1])
        rows.append([values[0], ids[key], values[1], values[2]])
    if not rows:
        raise RecordingError(f"{path}: no rows (expected 'frame id x y' per line)")
    data = np.array(rows)
    people = []
    for pid in range(len(names)):
        mine = data[data[:, 1] == pid]
        mine = mine[np.argsort(mine[:, 0], kind="stable")]
        if np.any(np.diff(mine[:, 0]) == 0):
            frame = mine[1:, 0][np.diff(mine[:, 0]) == 0][0]
            raise RecordingError(f"{path}: person {names[pid]} has two rows at frame {frame:g}")
        people.append(mine)
    steps = np.concatenate([np.diff(mine[:, 0]) for mine in people])
    max_gap_s = MAX_GAP_ROWS * float(np.median(steps)) * spf if steps.size else 0.0
    tracks, lone = [], 0
    for mine in people:
        t = mine[:, 0] * spf
        breaks = np.flatnonzero(np.diff(t) > max_gap_s * (1 + 1e-9)) + 1
        for piece_t, piece_xy in zip(np.split(t, breaks), np.split(mine[:, 2:4], breaks)):
            if len(piece_t) >= 2:
                tracks.append(np.column_stack([piece_t, piece_xy]))
            else:  # counted: until 2026-12-01 left out unsaid (a person of one row was simply not there)
                lone += 1
    if not tracks:
        raise RecordingError(f"{path}: no person has two rows in a row")
    tracks.sort(key=lambda tr: (tr[0, 0], tr[0, 1], tr[0, 2]))
    return Recording(recording_name(path), spf, tuple(tracks), len(people), lone)


def _person(token: str):
    """Who a row's id names: a number by its value (``1`` and ``1.0`` are one person; an integer
    exactly, however long: a tracker's 64-bit ids), anything else by its text (``ped1``). Until
    2026-12-01 the id was read as a float and bounded as a position: a tracker's id above 1e9 (or a
    frame that is a Unix time, with ``--seconds-per-frame 1``) was refused, ids beyond 2^53 made
    one person of several, and ``ped1`` was 'not a number'."""
    try:
        return int(token)
    except ValueError:
        pass
    try:
        v = float(token)
    except ValueError:
        return token
    return int(v) if v.is_integer() else v if math.isfinite(v) else None  # nan, inf: no one (a missing id)


NAME_LENGTH = 200
"""The longest recording name the cases take (characters): a case's file name adds up to 34
(``-across-back-000-social_force.toml``), within the 255 bytes of a file name (a longer one was
written to a name no file system takes: ``OSError: File name too long``, until 2026-12-01)."""


def recording_name(path) -> str:
    """The name a recording's cases are named after: its file's name without ``.gz`` and
    ``.txt``, every run of characters a scenario's name may not hold (CONTRACT.md: letters,
    digits, '_' and '-') made one '_', and no '-' or '_' first (a case named '-along-000.toml'
    reads as an option on a command line): ``crowds_zara01.txt.gz`` -> ``crowds_zara01``,
    ``my rec.txt`` -> ``my_rec``, ``zara.v2.txt`` -> ``zara_v2`` (cut at the first dot, two
    versions of a recording wrote over each other's cases; a space or a '+' made cases no
    command would read: found by an audit)."""
    stem = Path(path).name
    for ext in (".gz", ".txt"):
        if stem.lower().endswith(ext):
            stem = stem[:-len(ext)]
    return re.sub(r"[^A-Za-z0-9_-]+", "_", stem).lstrip("-_")[:NAME_LENGTH] or "recording"


def shipped_recording(name: str) -> Recording:
    """One of the recordings of :data:`SHIPPED`."""
    if name not in SHIPPED:
        raise ValueError(f"unknown recording {name!r} (shipped: {', '.join(SHIPPED)})")
    return read_recording(RECORDINGS_DIR / f"{name}.txt.gz")
