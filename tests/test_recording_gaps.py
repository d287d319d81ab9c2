"""Where a recorded person's track is split: more than MAX_GAP_ROWS of the recording's own row
steps without a row (scenarios.recordings). The rule was a fixed 1.2 s: right for rows 0.4 s
apart, a split at one missing row of biwi_eth's 0.667 s, and every track cut to single rows (the
file refused) where rows are more than 1.2 s apart."""
import numpy as np
import pytest

from scenarios.recordings import MAX_GAP_ROWS, RecordingError, read_recording


def _write(path, frames_by_person):
    lines = [f"{f} {pid} {0.1 * f:.3f} {float(pid):.1f}" for pid, frames in frames_by_person.items() for f in frames]
    path.write_text("\n".join(sorted(lines, key=lambda s: float(s.split()[0]))) + "\n")
    return path


def _pieces(rec):
    return sorted((round(float(tr[0, 0]), 6), len(tr)) for tr in rec.tracks)


def test_rows_two_seconds_apart_make_whole_tracks(tmp_path):
    f = _write(tmp_path / "slow.txt", {1: range(0, 100, 10), 2: range(20, 120, 10)})
    rec = read_recording(f, seconds_per_frame_s=0.2)  # rows 2 s apart
    assert _pieces(rec) == [(0.0, 10), (4.0, 10)]


@pytest.mark.parametrize("missing, pieces", [(1, 1), (MAX_GAP_ROWS - 1, 1), (MAX_GAP_ROWS, 2)])
def test_a_track_splits_where_more_than_the_rule_s_rows_are_missing(tmp_path, missing, pieces):
    """biwi_eth's step: frames 10 apart at 15 fps. Person 1 misses ``missing`` rows after its fifth
    (a gap of missing + 1 steps); person 2 is whole and sets the recording's row step."""
    frames = [f for f in range(0, 200, 10) if not 50 <= f < 50 + 10 * missing]
    rec = read_recording(_write(tmp_path / "eth.txt", {1: frames, 2: range(0, 200, 10)}), seconds_per_frame_s=1 / 15)
    step = 10 / 15
    assert len(rec.tracks) == 1 + pieces
    gaps = np.concatenate([np.diff(tr[:, 0]) for tr in rec.tracks])
    assert gaps.max() == pytest.approx(step * (missing + 1 if pieces == 1 else 1))


def test_a_file_of_single_rows_is_still_refused(tmp_path):
    with pytest.raises(RecordingError, match="no person has two rows in a row"):
        read_recording(_write(tmp_path / "one.txt", {1: [0], 2: [10]}))


def test_a_lone_row_is_counted_and_said(tmp_path, capsys):
    """A person with one row (or a row apart from the rest of theirs) cannot be followed: it was
    left out and nothing said so ('148 tracks' for a file of 149 people)."""
    from gpcnav.cli import main
    frames = {pid: range(10 * pid, 10 * pid + 300, 10) for pid in range(1, 9)}
    frames[99] = [100]                                                   # seen in one frame
    frames[7] = list(frames[7]) + [int(frames[7][-1]) + 10 * (MAX_GAP_ROWS + 2)]  # a row long after the rest
    rec = read_recording(_write(tmp_path / "lone.txt", frames))
    assert (rec.people, len(rec.tracks), rec.lone_rows) == (9, 8, 2)
    import gzip
    from scenarios.recordings import RECORDINGS_DIR
    rows = [r for r in gzip.decompress((RECORDINGS_DIR / "crowds_zara01.txt.gz").read_bytes()).decode().splitlines()
            if r.split() and float(r.split()[0]) <= 1500]               # its first 60 s: 29 people, cases
    (tmp_path / "zara.txt").write_text("\n".join(rows + ["100 999 5.0 5.0"]) + "\n")
    assert main(["import-tracks", str(tmp_path / "zara.txt"), "--out", str(tmp_path / "o"), "--max-cases", "1"]) == 0
    out = capsys.readouterr().out
    people = len({r.split()[1] for r in rows})
    assert f"{people + 1} people, {people} tracks, 1 row left out" in out, out
