"""Writing the user's files through the real commands (issue 13, cases 2, 3 and 4).

Outputs are checked before any work starts: never a device, a pipe, a
folder or a symlink to one; never two outputs that are one file; the folder
must exist. Each refusal is one line naming the path the user gave (never
the hidden temporary file), and nothing the user had is changed.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

from ..commands import one_clear_line, parts, run


def armtracker(*args: str, home: Path) -> "object":
    return run("tracker", *args, home=home)


def small_trial(path: Path, n: int = 400) -> Path:
    """A BROAD-format trial at rest, enough for ``fuse`` and ``evaluate``."""
    rng = np.random.default_rng(5)
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    np.savez(path, gyr=rng.normal(0, 0.01, (n, 3)), acc=np.tile([0, 0, 9.81], (n, 1)) + rng.normal(0, 0.05, (n, 3)),
             mag=np.tile([20.0, 0.0, -40.0], (n, 1)), quat=quat, rate=np.float64(100.0))
    return path


def devices_and_kin(tmp_path: Path) -> list[tuple[Path, str]]:
    """Outputs that are not regular files, each with the word the refusal must use."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    folder = tmp_path / "folder"
    folder.mkdir()
    link_to_null = tmp_path / "null-link"
    link_to_null.symlink_to("/dev/null")
    link_to_fifo = tmp_path / "fifo-link"
    link_to_fifo.symlink_to(fifo)
    outs = [(fifo, "pipe"), (folder, "folder"), (Path("/dev/null"), "character device"),
            (link_to_null, "character device"), (link_to_fifo, "pipe")]
    try:  # the issue's own case: a character device made with mknod (needs root)
        os.mknod(tmp_path / "null", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        outs.append((tmp_path / "null", "character device"))
    except PermissionError:
        pass
    return outs


def test_record_refuses_devices_pipes_and_folders_before_recording(tmp_path):
    for out, kind in devices_and_kin(tmp_path):
        before = os.stat(out)
        line = one_clear_line(armtracker("record", "--virtual", "--seconds", "5", "--raw", str(out), home=tmp_path),
                              str(out), kind)
        assert ".part" not in line
        after = os.stat(out)  # still the same node: not replaced by a regular file
        assert (after.st_ino, stat.S_IFMT(after.st_mode)) == (before.st_ino, stat.S_IFMT(before.st_mode))
    assert parts(tmp_path) == [] and parts(tmp_path / "folder") == []


def test_fuse_refuses_a_device_output(tmp_path):
    trial = small_trial(tmp_path / "t.npz")
    for out, kind in devices_and_kin(tmp_path):
        before = os.stat(out)
        one_clear_line(armtracker("fuse", str(trial), "--out", str(out), home=tmp_path), str(out), kind)
        assert os.stat(out).st_ino == before.st_ino
    assert parts(tmp_path) == []


def test_a_symlink_to_a_regular_file_is_written_through_and_kept(tmp_path):
    trial = small_trial(tmp_path / "t.npz")
    real = tmp_path / "real.npz"
    real.write_bytes(b"old")
    link = tmp_path / "link.npz"
    link.symlink_to(real)
    r = armtracker("fuse", str(trial), "--out", str(link), home=tmp_path)
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and os.readlink(link) == str(real)
    with np.load(real) as z:
        assert z["quat"].shape == (400, 4)


def test_record_refuses_one_file_for_raw_and_csv_in_any_spelling(tmp_path):
    keep = tmp_path / "x.bin"
    keep.write_bytes(b"an earlier recording")
    (tmp_path / "alias.bin").symlink_to(keep)
    (tmp_path / "sub").mkdir()
    spellings = [str(keep), str(tmp_path / "." / "x.bin"), str(tmp_path / "sub" / ".." / "x.bin"),
                 str(tmp_path / "alias.bin")]
    os.link(keep, tmp_path / "hard.bin")  # a hard link: another name, one file
    spellings.append(str(tmp_path / "hard.bin"))
    for other in spellings:
        one_clear_line(armtracker("record", "--virtual", "--seconds", "5", "--raw", str(keep), "--csv", other,
                                  home=tmp_path), "same file", other)
    assert keep.read_bytes() == b"an earlier recording"
    # A new file named twice is refused as well, before it exists.
    one_clear_line(armtracker("record", "--virtual", "--seconds", "5", "--raw", str(tmp_path / "new.bin"),
                              "--csv", str(tmp_path / "sub" / ".." / "new.bin"), home=tmp_path), "same file")
    assert not (tmp_path / "new.bin").exists() and parts(tmp_path) == []


@pytest.mark.parametrize("option", ["--raw", "--csv"])
def test_record_output_problems_are_said_before_the_board_is_opened(tmp_path, option):
    """A folder as output, or a folder that does not exist: one line naming the path, no ``.part`` anywhere."""
    other = ["--csv", str(tmp_path / "ok.csv")] if option == "--raw" else ["--raw", str(tmp_path / "ok.bin")]
    for out, words in ((tmp_path, "is a folder"), (tmp_path / "nowhere" / "x.out", "does not exist")):
        # A port that does not exist: had the board been opened first, this would be the error.
        line = one_clear_line(armtracker("record", "--port", str(tmp_path / "ttyNONE"), "--seconds", "5",
                                         option, str(out), *other, home=tmp_path), str(out), words)
        assert "ttyNONE" not in line and ".part" not in line
    assert parts(tmp_path) == [] and not (tmp_path / "ok.csv").exists() and not (tmp_path / "ok.bin").exists()


def test_a_bad_port_leaves_no_part_file(tmp_path):
    r = armtracker("record", "--port", str(tmp_path / "ttyNONE"), "--seconds", "5", "--raw", str(tmp_path / "x.bin"),
                   "--csv", str(tmp_path / "x.csv"), home=tmp_path)
    one_clear_line(r, "ttyNONE")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_experiment_plot_in_a_missing_folder_fails_before_the_run(tmp_path):
    r = armtracker("experiment", "static-drift", "--plot", str(tmp_path / "nonexist" / "x.png"), home=tmp_path)
    # One line and nothing else: the experiment's progress lines would come first had it run.
    one_clear_line(r, str(tmp_path / "nonexist" / "x.png"), "does not exist")
    assert r.stdout == ""


def test_evaluate_readme_problems_fail_before_the_evaluation(tmp_path):
    dataset = tmp_path / "trials"
    dataset.mkdir()
    small_trial(dataset / "a.npz")
    r = armtracker("evaluate", "--dataset", str(dataset), "--filter", "complementary", "--dof", "6",
                   "--readme", str(tmp_path / "nope.md"), home=tmp_path)
    one_clear_line(r, "nope.md")  # no "[1/1] ..." progress line: the evaluation never ran
    assert r.stdout == ""
    one_clear_line(armtracker("evaluate", "--dataset", str(dataset), "--readme", str(tmp_path), home=tmp_path),
                   str(tmp_path), "folder")

