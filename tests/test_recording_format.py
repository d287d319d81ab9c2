"""The ETH/UCY reader (scenarios.recordings.read_recording) on files as users bring them: a
byte-order mark, commas, ids that are words or tracker ids, frames that are Unix times, a header."""
import numpy as np
import pytest

from scenarios.recordings import RecordingError, read_recording


def _write(path, frames_by_person):
    lines = [f"{f} {pid} {0.1 * f:.3f} {float(pid):.1f}" for pid, frames in frames_by_person.items() for f in frames]
    path.write_text("\n".join(sorted(lines, key=lambda s: float(s.split()[0]))) + "\n")
    return path


@pytest.mark.parametrize("encoding, bom", [("utf-8", b"\xef\xbb\xbf"), ("utf-16-le", b"\xff\xfe"),
                                           ("utf-16-be", b"\xfe\xff")])
def test_a_file_saved_with_a_byte_order_mark_reads_as_without(tmp_path, encoding, bom):
    """Windows editors save UTF-8 with a byte-order mark (or UTF-16, which has one): the first
    row was 'not a number in '\\ufeff0 1 ...'', the numbers looking right."""
    plain = _write(tmp_path / "plain.txt", {1: range(0, 100, 10), 2: range(20, 120, 10)})
    marked = tmp_path / "marked.txt"
    marked.write_bytes(bom + plain.read_text().replace("\n", "\r\n").encode(encoding))
    a, b = read_recording(plain), read_recording(marked)
    assert len(a.tracks) == len(b.tracks) == 2
    assert all(np.array_equal(x, y) for x, y in zip(a.tracks, b.tracks))


def test_ids_are_names_and_frames_may_be_unix_times(tmp_path):
    """A person's id names them: a tracker's ids above 1e9 (and a frame that is a Unix time, read
    with one second a frame) were refused as 'numbers must be at most 1e+09', ids beyond 2^53 that
    differ made one person (two rows at a frame), and 'ped1' was not a number."""
    frames = {1: range(0, 100, 10), 2: range(20, 120, 10)}
    base = read_recording(_write(tmp_path / "base.txt", frames))
    big = {1: 2 ** 63 - 1, 2: 2 ** 63 - 2}
    for name, frame, pid in (("tracker", lambda f: f, lambda p: big[p]), ("named", lambda f: f, lambda p: f"ped{p}"),
                             ("unix", lambda f: 1354000000 + f * 0.04, lambda p: f"{p}.0")):
        rows = [f"{frame(f)} {pid(p)} {0.1 * f:.3f} {float(p):.1f}" for p, fs in frames.items() for f in fs]
        (tmp_path / f"{name}.txt").write_text("\n".join(rows) + "\n")
        rec = read_recording(tmp_path / f"{name}.txt", seconds_per_frame_s=1.0 if name == "unix" else None)
        assert rec.people == 2 and len(rec.tracks) == 2, name
        for a, b in zip(base.tracks, rec.tracks):
            assert np.allclose(a[:, 1:], b[:, 1:]) and np.allclose(a[:, 0] - a[0, 0], b[:, 0] - b[0, 0]), name
    (tmp_path / "twice.txt").write_text("0 ped1 1 1\n0 ped1 2 2\n")
    with pytest.raises(RecordingError, match="person ped1 has two rows at frame 0"):
        read_recording(tmp_path / "twice.txt")
    (tmp_path / "nan.txt").write_text("0 1 1 1\n10 1 2 2\n0 nan 1 1\n10 nan 2 2\n")  # a missing id: refused
    with pytest.raises(RecordingError, match="line 3: the id must be a finite number or a name, got nan"):
        read_recording(tmp_path / "nan.txt")
    (tmp_path / "far.txt").write_text("0 1 2e9 1\n10 1 2e9 2\n")
    with pytest.raises(RecordingError, match="positions must be at most 1e"):
        read_recording(tmp_path / "far.txt")


def test_commas_separate_columns_as_spaces_do_and_a_header_is_named(tmp_path):
    """A CSV export ('0,1,1.5,2.0', or ', ') was refused as 'expected four columns, got 1'; a
    header line is refused with a hint that it is one."""
    plain = _write(tmp_path / "plain.txt", {1: range(0, 100, 10), 2: range(20, 120, 10)})
    base = read_recording(plain)
    for sep in (",", ", ", " , "):
        f = tmp_path / "rec.csv"
        f.write_text(plain.read_text().replace(" ", sep))
        rec = read_recording(f)
        assert all(np.array_equal(a, b) for a, b in zip(base.tracks, rec.tracks)) and len(rec.tracks) == 2, sep
    f.write_text("frame,id,x,y\n" + plain.read_text().replace(" ", ","))
    with pytest.raises(RecordingError, match=r"line 1: not a number in 'frame,id,x,y' \(a header line\?"):
        read_recording(f)
    f.write_text("0,1,,2\n10,1,1,2\n")
    with pytest.raises(RecordingError, match=r"line 1: not a number in '0,1,,2'$"):
        read_recording(f)
    f.write_text("0,1,1,2,\n")
    with pytest.raises(RecordingError, match="expected four columns 'frame id x y', got 5"):
        read_recording(f)


def test_import_tracks_says_when_people_walk_at_no_walking_speed(tmp_path, capsys):
    """The frame time is not in the file: a recording whose first column is seconds (0.4, 0.8,
    ...) read at the default 1/25 s a frame had its people walk at 30 m/s, and import-tracks wrote
    its cases (or found none) saying nothing of it."""
    import gzip

    from gpcnav.cli import main
    from scenarios.recordings import RECORDINGS_DIR
    rows = [r.split() for r in gzip.decompress((RECORDINGS_DIR / "crowds_zara01.txt.gz").read_bytes()).decode()
            .splitlines() if r.split()]

    def seconds(last_frame):  # the recording with its frames written as seconds
        f = tmp_path / f"mine{last_frame}.txt"
        f.write_text("".join(f"{float(fr) / 25:.2f} {pid} {x} {y}\n" for fr, pid, x, y in rows
                             if float(fr) <= last_frame))
        return str(f)
    assert main(["import-tracks", seconds(2500), "--out", str(tmp_path / "a"), "--max-cases", "1"]) == 2  # 4 s
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no case" in err and "people walk at 30" in err, err
    assert main(["import-tracks", seconds(10 ** 6), "--out", str(tmp_path / "b"), "--max-cases", "1"]) == 0  # 14 s
    err = capsys.readouterr().err
    assert "note:" in err and "people walk at 30" in err and "is --seconds-per-frame right?" in err, err
    assert main(["import-tracks", seconds(10 ** 6), "--out", str(tmp_path / "c"), "--max-cases", "1",
                 "--seconds-per-frame", "1"]) == 0
    assert "walk at" not in capsys.readouterr().err
