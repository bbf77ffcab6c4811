"""`import vorl` against the `vorl` program: the same parts, the same messages.

Expected values come from the `vorl` program run at test time (`VORL_BIN`, else `cargo run
--release`) or from the bundled set's `truth.json`, never from this package's own output.
"""

import json
import os
import shlex
import subprocess
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

import vorl

ROOT = Path(__file__).resolve().parents[2]
PLANT = ROOT / "examples" / "plant"
FRAMES = sorted((PLANT / "frames").glob("*.png"))


def vorl_cli(*args, check=True):
    """Runs the `vorl` program; returns (stdout, stderr)."""
    if os.environ.get("VORL_BIN"):
        cmd = shlex.split(os.environ["VORL_BIN"])
    else:
        cmd = ["cargo", "run", "-q", "--release", "-p", "vorl-host-sim", "--bin", "vorl", "--"]
    out = subprocess.run(cmd + [str(a) for a in args], cwd=ROOT, capture_output=True, text=True)
    if check and out.returncode != 0:
        raise AssertionError(f"vorl {' '.join(map(str, args))} failed:\n{out.stderr}")
    return out.stdout, out.stderr


def cli_error(*args):
    """The one-line `error: …` message of a failing `vorl` run."""
    _, err = vorl_cli(*args, check=False)
    lines = [l for l in err.splitlines() if l.startswith("error: ")]
    assert lines, err
    return lines[-1][len("error: "):]


@pytest.fixture(scope="module")
def cli_plant():
    out, _ = vorl_cli("detect", PLANT, "--json")
    return json.loads(out)["frames"]


@pytest.fixture(scope="module")
def frames():
    return {p.name: vorl.imread(p) for p in FRAMES}


def test_the_bundled_set_is_there():
    assert len(FRAMES) >= 4, FRAMES


def test_detect_gives_what_the_program_gives_on_every_frame(cli_plant, frames):
    rec = vorl.Recognizer.from_set(PLANT)
    assert set(cli_plant) == set(frames)
    for name in sorted(frames):
        parts = rec.detect(frames[name])
        assert parts == cli_plant[name], name
    # Something was found and named (the comparison is not between two empty lists).
    assert sum(1 for ps in cli_plant.values() for p in ps if p["class"]) >= 10


def test_without_an_empty_shot_too(frames):
    # The platform estimated from the frames, one estimate kept while frames fit it: the same
    # frames in the same order give the same parts as the program's run over them.
    out, _ = vorl_cli("detect", "--background", "auto", "--templates", PLANT / "templates", "--json", *FRAMES)
    cli = json.loads(out)["frames"]
    rec = vorl.Recognizer(templates=PLANT / "templates")
    assert rec.auto_background
    for p in FRAMES:
        assert rec.detect(frames[p.name]) == cli[p.name], p.name


def test_config_file_and_parameters_as_the_program_takes_them(tmp_path, frames):
    cfg = tmp_path / "vorl.toml"
    cfg.write_text("threshold = 25\nrefine = \"off\"\n")
    out, _ = vorl_cli("detect", PLANT, "--config", cfg, "--candidates", "1", "--json")
    cli = json.loads(out)["frames"]
    by_file = vorl.Recognizer.from_set(PLANT, config=cfg, candidates=1)
    by_dict = vorl.Recognizer(
        templates=PLANT / "templates",
        background=[PLANT / "background.png", *sorted((PLANT / "backgrounds").glob("*.png"))],
        config={"threshold": 25, "refine": "off"},
        candidates=1,
    )
    assert by_file.config["threshold"] == 25 and by_file.config["refine"] == "off"
    for name in ("f000.png", "f003.png"):
        assert by_file.detect(frames[name]) == cli[name]
        assert by_dict.detect(frames[name]) == cli[name]


def test_config_defaults_are_the_programs(frames):
    tomllib = pytest.importorskip("tomllib")
    out, _ = vorl_cli("config", "--defaults")
    defaults = tomllib.loads(out)
    assert vorl.config_defaults() == defaults


# --- layouts: the caller's array however it is laid out -------------------------------------


@pytest.fixture(scope="module")
def plant_rec():
    return vorl.Recognizer.from_set(PLANT)


def test_any_strides_give_the_same_parts(plant_rec, frames):
    f = frames["f001.png"]
    want = plant_rec.detect(f)
    assert want
    h, w = f.shape
    big = np.zeros((h + 20, w + 31), np.uint8)
    big[7 : 7 + h, 13 : 13 + w] = f
    window = big[7 : 7 + h, 13 : 13 + w]  # a window into a larger image: rows padded
    assert not window.flags.c_contiguous
    fortran = np.asfortranarray(f)
    assert not fortran.flags.c_contiguous
    every_other = np.repeat(np.repeat(f, 2, axis=0), 2, axis=1)[::2, ::2]
    reversed_twice = f[::-1].copy()[::-1]  # negative row stride
    assert reversed_twice.strides[0] < 0
    readonly = f.copy()
    readonly.flags.writeable = False
    one_channel = f[:, :, np.newaxis]  # (H, W, 1), as some cv2 calls give
    for arr in (window, fortran, every_other, reversed_twice, readonly, one_channel):
        assert plant_rec.detect(arr) == want


def test_a_slice_of_rows_is_read_in_place_and_as_a_copy_alike(frames):
    # Rows 100-379: contiguous, read in place; the same rows as a fresh copy give the same parts.
    f = frames["f002.png"]
    part = f[100:380]
    assert part.flags.c_contiguous and part.base is not None
    rec = lambda: vorl.Recognizer(templates=PLANT / "templates", platform_every=1)  # noqa: E731
    assert rec().detect(part) == rec().detect(part.copy())


def test_the_frame_is_not_changed(plant_rec, frames):
    f = frames["f004.png"].copy()
    before = f.copy()
    plant_rec.detect(f)
    assert np.array_equal(f, before)


# --- errors: clear exceptions, the program's messages -----------------------------------------


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.uint16, np.int64, np.int8, np.bool_])
def test_a_wrong_dtype_is_refused(plant_rec, frames, dtype):
    with pytest.raises(vorl.VorlError, match="expected uint8"):
        plant_rec.detect(frames["f000.png"].astype(dtype))


@pytest.mark.parametrize(
    "shape, words",
    [((480, 640, 3), "3-channel"), ((480, 640, 4), "4-channel"), ((640,), "not an image"), ((2, 480, 640, 1), "not an image"), ((480, 640, 2), "not an image")],
)
def test_a_wrong_shape_is_refused(plant_rec, shape, words):
    with pytest.raises(vorl.VorlError, match=words) as e:
        plant_rec.detect(np.zeros(shape, np.uint8))
    if "channel" in words:
        assert "cv2.cvtColor" in str(e.value)


@pytest.mark.parametrize("shape", [(0, 0), (0, 640), (480, 0)])
def test_an_empty_array_is_refused(plant_rec, shape):
    with pytest.raises(vorl.VorlError, match="empty"):
        plant_rec.detect(np.zeros(shape, np.uint8))


def test_not_an_array_is_a_type_error(plant_rec):
    for thing in (None, [[1, 2], [3, 4]], "f000.png", 3):
        with pytest.raises(TypeError, match="NumPy array"):
            plant_rec.detect(thing)


def test_a_frame_of_another_size_than_the_empty_shot(plant_rec):
    with pytest.raises(vorl.VorlError, match=r"frame is 320×240 but the background is 640×480"):
        plant_rec.detect(np.zeros((240, 320), np.uint8))


def test_errors_are_value_errors_with_the_programs_message(tmp_path):
    assert issubclass(vorl.VorlError, ValueError)
    missing = tmp_path / "no-templates"
    want = cli_error("detect", "--background", PLANT / "background.png", "--templates", missing, FRAMES[0])
    with pytest.raises(vorl.VorlError) as e:
        vorl.Recognizer(templates=missing, background=PLANT / "background.png")
    assert str(e.value) == want
    assert "\n" not in str(e.value)
    empty = tmp_path / "empty"
    empty.mkdir()
    want = cli_error("detect", "--background", PLANT / "background.png", "--templates", empty, FRAMES[0])
    with pytest.raises(vorl.VorlError) as e:
        vorl.Recognizer(templates=empty)
    assert str(e.value) == want
    want = cli_error("detect", tmp_path / "no-set")
    with pytest.raises(vorl.VorlError) as e:
        vorl.Recognizer.from_set(tmp_path / "no-set")
    assert str(e.value) == want
    with pytest.raises(vorl.VorlError) as e:
        vorl.imread(tmp_path / "missing.png")
    assert str(e.value) == cli_error("detect", "--background", tmp_path / "missing.png", "--templates", PLANT / "templates", FRAMES[0])


def test_bad_parameters_are_refused():
    with pytest.raises(vorl.VorlError, match="unknown field `no_such_key`"):
        vorl.Recognizer(no_such_key=1)
    with pytest.raises(vorl.VorlError, match="invalid parameters"):
        vorl.Recognizer(alpha=3.0)
    with pytest.raises(vorl.VorlError):
        vorl.Recognizer(threshold=[1, 2])


def test_a_silhouette_that_is_not_one_part_is_refused(plant_rec):
    with pytest.raises(vorl.VorlError, match="no part"):
        plant_rec.add_template("blank", np.zeros((50, 50), np.uint8))
    two = np.zeros((60, 120), np.uint8)
    two[10:50, 10:50] = 255
    two[10:50, 70:110] = 255
    with pytest.raises(vorl.VorlError, match="separate blobs"):
        plant_rec.add_template("two", two)
    with pytest.raises(vorl.VorlError, match="empty"):
        plant_rec.add_template("", two)


# --- teach, then detect ----------------------------------------------------------------------


def truth_part(frame_name):
    """A whole, known part of a frame from the set's truth.json (the generator's truth)."""
    truth = json.loads((PLANT / "truth.json").read_text())["frames"][frame_name]
    return next(p for p in truth if p["class"] and not p.get("partial"))


def test_teach_gives_the_silhouette_the_program_saves(tmp_path, frames):
    t = truth_part("f000.png")
    at = (round(t["x"]), round(t["y"]))
    vorl_cli("teach", FRAMES[0], "--at", f"{at[0]},{at[1]}", "--background", PLANT / "background.png", "--name", "thing", "--out", tmp_path)
    saved = vorl.imread(tmp_path / "thing.png")
    sil = vorl.teach(frames["f000.png"], at=at, background=PLANT / "background.png")
    assert sil.dtype == np.uint8 and sil.ndim == 2
    assert np.array_equal(sil, saved)
    # Without an empty shot (the platform estimated from the frame), with info.
    vorl_cli("teach", FRAMES[0], "--at", f"{at[0]},{at[1]}", "--name", "auto", "--out", tmp_path)
    sil, info = vorl.teach(frames["f000.png"], at=at, return_info=True)
    assert np.array_equal(sil, vorl.imread(tmp_path / "auto.png"))
    assert info["auto_background"] is True and info["polarity"] in ("either", "darker", "brighter")


def test_teach_then_detect_finds_the_taught_part(frames):
    t = truth_part("f000.png")
    bg = vorl.imread(PLANT / "background.png")
    sil = vorl.teach(frames["f000.png"], at=(t["x"], t["y"]), background=bg)
    rec = vorl.Recognizer(background=bg)
    assert rec.detect(frames["f000.png"]) and all(p["class"] is None for p in rec.detect(frames["f000.png"]))
    rec.add_template("taught", sil)
    assert rec.classes == ["taught"]
    found = [p for p in rec.detect(frames["f000.png"]) if p["class"] == "taught"]
    assert any(abs(p["x"] - t["x"]) < 1.0 and abs(p["y"] - t["y"]) < 1.0 for p in found), (found, t)
    # The same class on another frame, wherever the truth has it whole.
    for name in sorted(frames):
        truth = json.loads((PLANT / "truth.json").read_text())["frames"][name]
        for p in truth:
            if p["class"] == t["class"] and not p.get("partial"):
                parts = rec.detect(frames[name])
                assert any(q["class"] == "taught" and abs(q["x"] - p["x"]) < 1.0 and abs(q["y"] - p["y"]) < 1.0 for q in parts), (name, p, parts)


def test_teach_refuses_what_names_no_part(frames):
    with pytest.raises(vorl.VorlError, match="no part of frame lies there"):
        vorl.teach(frames["f000.png"], at=(2, 2), background=PLANT / "background.png")
    with pytest.raises(vorl.VorlError, match="--part 99"):
        vorl.teach(frames["f000.png"], part=99, background=PLANT / "background.png")
    with pytest.raises(vorl.VorlError, match="no part found"):
        vorl.teach(vorl.imread(PLANT / "background.png"), background=PLANT / "background.png")


def test_a_second_example_of_a_class(frames):
    t = truth_part("f000.png")
    sil = vorl.teach(frames["f000.png"], at=(t["x"], t["y"]), background=PLANT / "background.png")
    rec = vorl.Recognizer(background=PLANT / "background.png")
    rec.add_template("a", sil)
    rec.add_template("a", np.rot90(sil).copy())
    assert rec.classes == ["a"]
    assert any(p["class"] == "a" for p in rec.detect(frames["f000.png"]))


# --- threads ----------------------------------------------------------------------------------


def test_two_threads_on_two_recognisers(frames):
    names = sorted(frames)
    want = {n: vorl.Recognizer.from_set(PLANT).detect(frames[n]) for n in names}
    got = [dict(), dict()]
    errors = []

    def work(k):
        try:
            rec = vorl.Recognizer.from_set(PLANT)
            for _ in range(3):
                for n in names if k == 0 else reversed(names):
                    got[k].setdefault(n, []).append(rec.detect(frames[n]))
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for k in range(2):
        for n in names:
            assert all(r == want[n] for r in got[k][n]), (k, n)


def test_one_recogniser_shared_by_threads_takes_turns(plant_rec, frames):
    names = sorted(frames)
    want = {n: plant_rec.detect(frames[n]) for n in names}
    bad = []

    def work():
        for n in names:
            if plant_rec.detect(frames[n]) != want[n]:
                bad.append(n)

    threads = [threading.Thread(target=work) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not bad


def test_notes_are_warnings(plant_rec):
    # A frame that differs from the empty shot over most of it: the program's note, a warning.
    dark = np.zeros((480, 640), np.uint8)
    dark[100:380, 100:540] = 255
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plant_rec.detect(dark)
    assert any(issubclass(w.category, vorl.VorlWarning) and "differs from the background" in str(w.message) for w in caught), [str(w.message) for w in caught]
