"""Hypothesis fuzzing of the file readers: every mutant of a valid file is read or refused in one line.

Readers: scene TOML (whisker.sim.load_scene), recording sessions (whisker.data.session.load_session),
datasets (whisker.data.dataset_files.load_csv_folder), classifier models (whisker.data.classify.load_model) and lens
calibration files (whisker.vision.markers.load_calibration). Mutations of a valid file: truncation, byte
flips, wrong columns (a header renamed or a column dropped), and numbers replaced by NaN, inf or
1e308. For every mutant:

- the reader returns (the mutant is still valid) or raises its own one-line error (SceneError,
  RecordingError, DatasetError, ValueError for calibration), never anything else;
- nothing on disk changed (every file's bytes and the folder listing are the same after reading).

Budget: WHISKER_FUZZ_EXAMPLES mutants per reader (default 25 in the test suite; `make fuzz` runs
400 and writes benchmarks/results/fuzz_readers.md through WHISKER_FUZZ_REPORT).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test_dataset import synthetic
from test_recording_plot import make_trial

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = int(os.environ.get("WHISKER_FUZZ_EXAMPLES", "25"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=not os.environ.get("WHISKER_FUZZ_RANDOM"),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])
TALLY: dict[str, Counter] = {}


# ---------------------------------------------------------------------------------------------
# mutations
# ---------------------------------------------------------------------------------------------
NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")


@st.composite
def mutation(draw, size: int, text: bool):
    """(kind, function bytes -> bytes) for a file of `size` bytes."""
    kinds = ["truncate", "flip"] + (["nan", "columns"] if text else [])
    kind = draw(st.sampled_from(kinds))
    if kind == "truncate":
        n = draw(st.integers(0, max(0, size - 1)))
        return kind, lambda b: b[:n]
    if kind == "flip":
        flips = draw(st.lists(st.tuples(st.integers(0, max(0, size - 1)), st.integers(1, 255)), min_size=1, max_size=4))

        def flip(b):
            a = bytearray(b)
            for i, x in flips:
                if i < len(a):
                    a[i] ^= x
            return bytes(a)
        return kind, flip
    if kind == "nan":
        which = draw(st.integers(0, 10_000))
        token = draw(st.sampled_from([b"nan", b"inf", b"-inf", b"1e308", b"-1e308", b"", b"x"]))

        def nan(b):
            hits = list(NUMBER.finditer(b))
            if not hits:
                return b
            m = hits[which % len(hits)]
            return b[:m.start()] + token + b[m.end():]
        return kind, nan
    col = draw(st.integers(0, 50))
    drop = draw(st.booleans())

    def columns(b):
        lines = b.split(b"\n")
        head = lines[0].split(b",")
        if drop:
            return b"\n".join(b",".join(c for i, c in enumerate(ln.split(b",")) if i != col % len(head))
                              for ln in lines)
        head[col % len(head)] = b"bogus_column"
        return b"\n".join([b",".join(head), *lines[1:]])
    return kind, columns


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
            for p in sorted(folder.rglob("*"))}


def check(reader: str, read, folder: Path, errors: tuple) -> None:
    """Run `read()`; tally its outcome; refuse anything but success or a one-line domain error."""
    before = snapshot(folder)
    try:
        read()
        outcome = "read"
    except errors as err:
        msg = str(err)
        assert msg and "\n" not in msg.strip(), f"{reader}: multi-line message {msg!r}"
        outcome = "refused"
    after = snapshot(folder)
    assert after == before, f"{reader}: reading changed files on disk"
    TALLY.setdefault(reader, Counter())[outcome] += 1


def mutate_copy(src: Path, rel: str, fn) -> Path:
    """A fresh copy of `src` (a file or folder) with file `rel` inside it mutated by `fn`."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-"))
    dst = tmp / src.name
    if src.is_dir():
        shutil.copytree(src, dst)
        target = dst / rel
    else:
        shutil.copy(src, dst)
        target = dst
    target.write_bytes(fn(target.read_bytes()))
    return dst


# ---------------------------------------------------------------------------------------------
# valid files
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    from whisker.data.classify import fit_quiet, make_classifier, save_model
    from whisker.data.dataset_files import write_csv_folder
    from whisker.design import default_design

    base = tmp_path_factory.mktemp("valid")
    ds = synthetic(n_obj=2, trials=2, poses=3, R=1, W=8)
    write_csv_folder(ds, base / "data")
    save_model(base / "model.joblib", fit_quiet(make_classifier(seed=0, epochs=2), ds.features(), ds.y), ds,
               {"protocol": "random", "feature_limit_px": 100.0})
    make_trial(base / "session", default_design(), offset_s=0.2, amplitude=2.0)
    np.savez(base / "calib.npz", mtx=np.array([[349.0, 0, 320], [0, 349.0, 240], [0, 0, 1]]),
             dist=np.array([-0.3, 0.1, 0.0, 0.0, 0.0]))
    return base


SCENES = sorted((ROOT / "software/whisker/sim/scenes").glob("*.toml"))


def _clean(path: Path) -> None:
    shutil.rmtree(path.parent, ignore_errors=True)


# ---------------------------------------------------------------------------------------------
# the readers
# ---------------------------------------------------------------------------------------------
@FUZZ
@given(data=st.data())
def test_scene_toml(data):
    from whisker.sim import SceneError, load_scene

    src = data.draw(st.sampled_from([s for s in SCENES if "objects_from" not in s.read_text()] or SCENES))
    kind, fn = data.draw(mutation(src.stat().st_size, text=True))
    folder = Path(tempfile.mkdtemp(prefix="fuzz-"))
    try:
        f = folder / src.name
        f.write_bytes(fn(src.read_bytes()))
        check("scene TOML", lambda: load_scene(f), folder, (SceneError,))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@FUZZ
@given(data=st.data())
def test_recording_session(valid, data):
    from whisker.data.recording import RecordingError
    from whisker.data.session import load_session
    from whisker.data.recplot import fig8_data

    rel = data.draw(st.sampled_from(["metadata.json", "frames.csv", "tracks.csv", "actuation.csv"]))
    size = (valid / "session" / rel).stat().st_size
    kind, fn = data.draw(mutation(size, text=True))
    s = mutate_copy(valid / "session", rel, fn)
    try:
        def read():
            sess = load_session(s)
            try:
                fig8_data([sess])      # recplot's reading of it: a figure or a one-line refusal
            except ValueError as err:
                assert "\n" not in str(err)
        check("recording session", read, s, (RecordingError,))
    finally:
        _clean(s)


@FUZZ
@given(data=st.data())
def test_dataset_folder(valid, data):
    from whisker.data.dataset import DatasetError
    from whisker.data.dataset_files import load_csv_folder

    rel = data.draw(st.sampled_from(["obj0.csv", "obj1.csv", "dataset.json"]))
    kind, fn = data.draw(mutation((valid / "data" / rel).stat().st_size, text=True))
    d = mutate_copy(valid / "data", rel, fn)
    try:
        check("dataset", lambda: load_csv_folder(d), d, (DatasetError,))
    finally:
        _clean(d)


@FUZZ
@given(data=st.data())
def test_model_file(valid, data):
    import warnings

    from whisker.data.classify import load_model, predict
    from whisker.data.dataset import DatasetError

    kind, fn = data.draw(mutation((valid / "model.joblib").stat().st_size, text=False))
    m = mutate_copy(valid / "model.joblib", "", fn)
    try:
        def read():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                b = load_model(m)
            labels, proba = predict(b, np.zeros((1, b["n_records"] * b["n_whiskers"] * 2)))
            assert len(labels) == 1
        check("model", read, m.parent, (DatasetError,))
    finally:
        _clean(m)


@FUZZ
@given(data=st.data())
def test_calibration_file(valid, data):
    from whisker.vision.markers import load_calibration

    kind, fn = data.draw(mutation((valid / "calib.npz").stat().st_size, text=False))
    c = mutate_copy(valid / "calib.npz", "", fn)
    try:
        check("calibration", lambda: load_calibration(c), c.parent, (ValueError,))
    finally:
        _clean(c)


def test_zz_report():
    """With WHISKER_FUZZ_REPORT set (make fuzz): the tally per reader as a table and a bar figure."""
    report = os.environ.get("WHISKER_FUZZ_REPORT")
    assert all(sum(c.values()) > 0 for c in TALLY.values())
    if not report:
        return
    from whisker.files import atomic_write_bytes, atomic_write_text

    lines = [f"# Reader fuzzing: {EXAMPLES} mutants per reader", "",
             "Mutations: truncation, byte flips, wrong columns, numbers -> NaN/inf/1e308 (tests/test_fuzz_readers.py).",
             "Every mutant was read or refused in one line; no file changed on disk.", "",
             "| reader | read | refused |", "|---|---|---|"]
    lines += [f"| {r} | {c['read']} | {c['refused']} |" for r, c in sorted(TALLY.items())]
    atomic_write_text(report, "\n".join(lines) + "\n")
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted(TALLY)
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.barh(names, [TALLY[n]["read"] for n in names], label="read")
    ax.barh(names, [TALLY[n]["refused"] for n in names], left=[TALLY[n]["read"] for n in names], label="refused")
    ax.set_xlabel("mutants")
    ax.legend()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    atomic_write_bytes(Path(report).with_suffix(".png"), buf.getvalue())
