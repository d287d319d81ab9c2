"""Read a recording of pedestrians (the ETH/UCY four-column format, 'frame id x y') and write
one scenario file per case of the case protocol (docs/pedestrians.md), the people as
movers that follow their recorded tracks."""
from __future__ import annotations

import math
import sys
from pathlib import Path

from ..errors import UsageError
from .common import check_name_lengths, check_regular_file, check_writable_folder, make_output_folder, progress


def add_arguments(p):
    p.add_argument("recording", type=Path,
                   help="the recording: rows 'frame id x y', separated by spaces, tabs or commas (plain text or gzip)")
    p.add_argument("--out", type=Path, required=True, help="folder for the scenario files (made if missing)")
    p.add_argument("--seconds-per-frame", type=float, default=None, metavar="S",
                   help="what one frame id lasts (default: 1/15 s for biwi_eth and its parts, biwi_eth_train "
                        "and so on: a 15 fps video; 1/25 s for the others: the UCY files, biwi_hotel)")
    p.add_argument("--behaviour", choices=("replay", "orca", "social_force"), default="replay",
                   help="the people: replayed open loop (default), or walkers that follow their recording "
                        "and give way to the robot (orca, social_force)")
    p.add_argument("--max-cases", type=int, default=None, metavar="N",
                   help="write at most N cases, spread evenly over all of them, each the same file as without it "
                        "(its noise seed is its place among all; default: every case)")


def run(args) -> int:
    import tomllib
    from scenarios import load_scenario
    from scenarios.loader import scenario_from_dict
    from scenarios.pedestrian_cases import APPEAR_WITHIN_S, START_CLEARANCE_M, case_scenario, cases
    from scenarios.writer import scenario_document, to_toml
    from scenarios.recordings import MAX_GAP_ROWS, WALKING_SPEEDS_MPS, RecordingError, read_recording
    from casadi_gpc.io import write_text
    if args.seconds_per_frame is not None and not (math.isfinite(args.seconds_per_frame)
                                                   and args.seconds_per_frame > 0):
        raise UsageError(f"--seconds-per-frame must be a positive number, got {args.seconds_per_frame}")
    if args.max_cases is not None and args.max_cases < 1:
        raise UsageError(f"--max-cases must be at least 1, got {args.max_cases}")
    check_name_lengths(args.out, f"--out {args.out}")
    try:
        rec = read_recording(args.recording, args.seconds_per_frame)
    except RecordingError as exc:
        raise UsageError(str(exc)) from None
    speed, (slow, fast) = rec.walking_speed_mps, WALKING_SPEEDS_MPS
    doubt = ("" if slow <= speed <= fast else  # the frame time is not in the file: 1/25 s taken for one of seconds
             f"at {rec.seconds_per_frame:.4g} s a frame its people walk at {speed:.3g} m/s (median; people walk about "
             f"1 m/s): is --seconds-per-frame right?")
    skipped = {}
    found = cases(rec, skipped)
    if not found:
        raise UsageError(f"{args.recording}: no case of the protocol in this recording (docs/pedestrians.md: at "
                         f"least 5 people in the busiest 6 m square, the robot's start clear)"
                         + (f"; {doubt}" if doubt else ""))
    # a case's noise seed is its place among all the recording's cases, whatever --max-cases picks (it was
    # its place among those written: the same case, made with another --max-cases, drew other noise)
    numbered = list(enumerate(found))
    if args.max_cases is not None and args.max_cases < len(found):
        step = len(found) / args.max_cases
        numbered = [numbered[int(k * step)] for k in range(args.max_cases)]
    # every file made and read back before the first is written: a case that would not load
    # leaves nothing behind
    texts = {}
    for k, case in progress(numbered, desc="cases", unit="case"):  # (students003: 178 cases, 26 s)
        sc = case_scenario(rec, case, args.behaviour, seed=k)
        path = args.out / f"{sc.name}.toml"
        texts[path] = to_toml(scenario_document(sc))
        try:
            scenario_from_dict(tomllib.loads(texts[path]), str(path))
        except ValueError as exc:
            raise UsageError(f"{args.recording}: case {sc.name} would not load: {exc}") from None
    for path in texts:  # a case's name taken by a folder or a device: said before any file is written
        if path.is_dir():
            raise UsageError(f"--out {args.out}: {path.name} is a folder, not a file: case {path.stem} cannot be "
                             f"written (nothing was written)")
        check_regular_file(path, f"--out {args.out}: {path.name}")
    check_writable_folder(args.out, f"--out {args.out}")  # a folder where no file can be made (/proc, read-only)
    make_output_folder(args.out, "--out")
    others = sorted(set(args.out.glob("*.toml")) - set(texts))
    for path, text in texts.items():
        write_text(path, text)
    load_scenario(path)  # the last one read back from its file
    if others:  # cases of another recording or run: a glob of the folder takes them too
        print(f"note: {args.out} also holds {len(others)} other scenario files (e.g. {others[0].name}), "
              f"not written by this run", file=sys.stderr)
    lone = (f", {rec.lone_rows} row{'s' * (rec.lone_rows != 1)} left out (no other row of the person within "
            f"{MAX_GAP_ROWS} row steps: nothing to follow)" if rec.lone_rows else "")
    if doubt:
        print(f"note: {args.recording}: {doubt}", file=sys.stderr)
    n_tracks = len(rec.tracks)
    people = f"{rec.people} {'person' if rec.people == 1 else 'people'}, {n_tracks} track{'s' * (n_tracks != 1)}"
    print(f"{args.recording}: {people}{lone}, {rec.end_s - rec.start_s:.0f} s "
          f"({rec.seconds_per_frame:.4g} s per frame); {len(numbered)} case{'s' * (len(numbered) != 1)} written to "
          f"{args.out}{_skipped(skipped, START_CLEARANCE_M, APPEAR_WITHIN_S)}", file=sys.stdout)
    return 0


def _skipped(skipped: dict, clearance_m: float, within_s: float) -> str:
    """The starts left out, said after the cases written: someone within ``clearance_m`` of the
    robot's disc at the start, or appearing there within ``within_s``."""
    n = sum(skipped.values())
    if not n:
        return ""
    return (f" ({n} start{'s' * (n != 1)} skipped, someone within {clearance_m:g} m of the robot's disc: "
            f"{skipped.get('occupied', 0)} there at the start, {skipped.get('appears', 0)} appearing within "
            f"{within_s:g} s)")
