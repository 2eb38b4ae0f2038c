"""`whisker classify`: train, evaluate and use the paper's object classifier (MLP on whisker contacts)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import click

from whisker.cliutil import design_options, fail

PROTOCOL_HELP = ("paper = rotate then split (the paper); random = 7:3 split of the recorded samples "
                 "(the authors' notebook); trial = hold out whole trials; pose = hold out an arc of "
                 "object orientations; '+rot' = add the 360/N rotations after the split (leak-free).")


def _data_option(f):
    return click.option("--data", "data", type=click.Path(file_okay=False), default=None,
                        help="Dataset folder of <object>.csv files: the authors' objCls folder (or its "
                             "parent), a simulated dataset, or one written by "
                             "whisker.data.dataset_files.write_csv_folder. Default: $WHISKER_PEER_DATA.")(f)


def _objects_option(f):
    return click.option("--objects", default=None, metavar="A,B,..|paper",
                        help="Only these objects; 'paper' = the paper's five "
                             "(cherry, eraser, lightbulb, strawberry, yuanbao). Default: all.")(f)


def _mlp_options(f):
    for opt in reversed([
        click.option("--hidden", default=32, show_default=True, type=click.IntRange(1), help="Hidden ReLU units."),
        click.option("--epochs", default=10, show_default=True, type=click.IntRange(1), help="Adam epochs."),
        click.option("--lr", default=0.01, show_default=True, type=click.FloatRange(min=0, min_open=True),
                     help="Adam learning rate."),
        click.option("--batch-size", default=16, show_default=True, type=click.IntRange(1), help="Mini-batch size."),
    ]):
        f = opt(f)
    return f


KIND_HELP = ("Model: mlp = the paper's MLP (the --hidden/--epochs/--lr/--batch-size options apply to it only); "
             "svc = polar features (log |d|, direction per whisker and record) + RBF SVM, the best held-out "
             "accuracy on the authors' data; trees = polar features + extra trees; hgb = polar features + "
             "gradient boosting; dft-svc = cyclic-shift-invariant DFT features + RBF SVM "
             "(docs/classification.md).")


def _kind_option(f):
    from whisker.data.models import KINDS

    return click.option("--kind", type=click.Choice(KINDS), default="mlp", show_default=True, help=KIND_HELP)(f)


def _params(kind, ds, hidden, epochs, lr, batch_size):
    from whisker.data import classify as C

    if kind != "mlp":
        return {}
    return dict(hidden=hidden, epochs=epochs, lr=lr, batch_size=batch_size, scale=ds.meta.get("scale") or C.PEER_SCALE)


def _load(data, objects, design):
    from whisker.data.dataset import PAPER_OBJECTS, DatasetError, check_design, check_plausible, feature_limit_px
    from whisker.data.dataset_files import load

    data = data or os.environ.get("WHISKER_PEER_DATA")
    if not data:
        fail("no dataset: give --data DIR or set WHISKER_PEER_DATA")
    names = None
    if objects:
        names = list(PAPER_OBJECTS) if objects == "paper" else [o.strip() for o in objects.split(",") if o.strip()]
    try:
        ds = load(data, names, design)
        check_design(ds, design)
        check_plausible(ds.X, feature_limit_px(design), str(data))
    except (DatasetError, OSError) as err:
        fail(f"dataset refused: {err}")
    return ds


@click.group()
def cli():
    """Object classification from whisker contacts (the paper's MLP: 32 ReLU units, Adam lr 0.01,
    10 epochs, 7:3 split, or --kind svc/trees/hgb/dft-svc) with honest, leak-free evaluation protocols."""


@cli.command()
@design_options
@_data_option
@_objects_option
@_mlp_options
@_kind_option
@click.option("--protocol", default="trial", show_default=True, help=PROTOCOL_HELP)
@click.option("--seed", default=0, show_default=True, type=int, help="Split and initialisation seed.")
@click.option("--all-data", is_flag=True, help="Train on every sample with no test split (plus the rotated "
                                               "copies if the protocol is 'paper' or ends in '+rot').")
@click.option("--out", "out", type=click.Path(dir_okay=False), required=True, help="Model file to write (.joblib).")
@click.option("--report", type=click.Path(file_okay=False), default=None,
              help="Folder for the per-class report (report.txt, metrics.json) and confusion.png.")
def train(design, data, objects, hidden, epochs, lr, batch_size, kind, protocol, seed, all_data, out, report):
    """Train the classifier and save it with the library versions it was trained with."""
    import numpy as np

    from whisker.cliutil import check_out_path, exclusive_out

    check_out_path(out, "classify train")
    if report:
        check_out_path(report, "classify train", folder=True)

    from whisker.data import classify as C
    from whisker.data.dataset import DatasetError, augment_rotations
    from whisker.files import atomic_write_json, atomic_write_text

    lock = exclusive_out(out, "classify train")
    lock.__enter__()
    from whisker.data.models import make_model

    ds = _load(data, objects, design)
    params = _params(kind, ds, hidden, epochs, lr, batch_size)
    try:
        C.check_classes(ds)
        if all_data:
            if protocol not in C.PROTOCOLS:
                raise ValueError(f"unknown protocol {protocol!r}; choose from {', '.join(C.PROTOCOLS)}")
            rotated = protocol == "paper" or protocol.endswith("+rot")
            train_ds, test_ds = (augment_rotations(ds) if rotated else ds), None
        else:
            train_ds, test_ds = C.split(ds, protocol, seed)
        model = C.fit_quiet(make_model(kind, seed=seed, n_records=ds.n_records, n_whiskers=ds.n_whiskers, **params),
                            train_ds.features(), train_ds.y)
    except (DatasetError, ValueError) as err:
        fail(f"training refused: {err}")
    from whisker.data.dataset import feature_limit_px

    info = {"kind": kind, "params": params, "protocol": None if all_data else protocol, "seed": seed,
            "trained_on": ds.summary(), "design_whiskers": design.whiskers.count,
            "feature_limit_px": feature_limit_px(design)}
    if test_ds is not None:
        pred = model.predict(test_ds.features())
        acc = float(np.mean(pred == test_ds.y))
        info["test_accuracy"] = acc
        click.echo(f"test accuracy ({protocol}, seed {seed}, {len(test_ds)} samples): {acc:.4f}")
        text = C.per_class_report(test_ds.y, pred, ds.classes)
        click.echo(text)
        if report:
            from sklearn.metrics import confusion_matrix

            cm = confusion_matrix(test_ds.y, pred, labels=list(ds.classes))
            atomic_write_text(Path(report) / "report.txt", text)
            atomic_write_json(Path(report) / "metrics.json", {"accuracy": acc, "protocol": protocol, "seed": seed,
                                                              "classes": list(ds.classes), "confusion": cm.tolist()})
            C.plot_confusion(cm, ds.classes, Path(report) / "confusion.png",
                             f"{protocol}, seed {seed}: accuracy {acc:.3f}")
    try:
        C.save_model(out, model, ds, info)
    except OSError as err:
        fail(f"classify train: cannot write the model {out}: {err.strerror or err}", code=1)
    finally:
        lock.__exit__(None, None, None)
    click.echo(f"model -> {out}")


@cli.command()
@design_options
@_data_option
@_objects_option
@_mlp_options
@click.option("--model", "model_file", type=click.Path(dir_okay=False), default=None,
              help="Evaluate this saved model on the whole dataset instead of running the protocol study.")
@click.option("--protocol", "protocols", multiple=True, help=PROTOCOL_HELP + " Repeatable; default: all.")
@click.option("--seeds", default=10, show_default=True, type=click.IntRange(1), help="Seeds per protocol.")
@_kind_option
@click.option("--jobs", default=1, show_default=True, type=click.IntRange(1),
              help="Parallel fits (joblib workers, one per seed and protocol).")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Folder for results.json, results.md and confusion_<protocol>.png.")
def evaluate(design, data, objects, hidden, epochs, lr, batch_size, model_file, protocols, seeds, kind, jobs, out):
    """Accuracy (mean +- std over seeds) under each protocol, or of a saved model on a dataset."""
    import numpy as np

    from whisker.data import classify as C
    from whisker.data.dataset import DatasetError
    from whisker.files import atomic_write_json, atomic_write_text

    ds = _load(data, objects, design)
    if model_file:
        try:
            bundle = C.load_model(model_file)
            C.check_labels(bundle, ds.y)
            pred, _ = C.predict(bundle, ds.features(), ds.valid)
        except DatasetError as err:
            fail(f"evaluation refused: {err}")
        acc = float(np.mean(pred == ds.y))
        click.echo(f"accuracy of {model_file} on {len(ds)} samples: {acc:.4f}")
        click.echo(C.per_class_report(ds.y, pred, bundle["classes"]))
        if out:
            from sklearn.metrics import confusion_matrix

            cm = confusion_matrix(ds.y, pred, labels=bundle["classes"])
            atomic_write_json(Path(out) / "results.json", {"model": str(model_file), "accuracy": acc,
                                                           "classes": bundle["classes"], "confusion": cm.tolist()})
            C.plot_confusion(cm, bundle["classes"], Path(out) / "confusion_model.png", f"accuracy {acc:.3f}")
        return
    protocols = protocols or C.PROTOCOLS
    bad = [p for p in protocols if p not in C.PROTOCOLS]
    if bad:
        fail(f"unknown protocol(s) {bad}; choose from {', '.join(C.PROTOCOLS)}")
    params = _params(kind, ds, hidden, epochs, lr, batch_size)
    try:
        summary = C.summarize(C.study(ds, protocols, range(seeds), progress=True, n_jobs=jobs, kind=kind, **params))
    except (DatasetError, ValueError) as err:
        fail(f"evaluation refused: {err}")
    lines = [f"| protocol | accuracy mean +- std ({seeds} seeds) | min | train / test samples |", "|---|---|---|---|"]
    for p, v in summary.items():
        lines.append(f"| {p} | {100 * v['accuracy_mean']:.2f} +- {100 * v['accuracy_std']:.2f} % | "
                     f"{100 * v['accuracy_min']:.2f} % | {v['n_train']} / {v['n_test']} |")
    lines.append(f"| the paper (5 objects) | {100 * C.PAPER_ACCURACY:.2f} % | | |")
    click.echo("\n".join(lines))
    if out:
        atomic_write_json(Path(out) / "results.json", {"kind": kind, "params": params, "objects": list(ds.classes), "protocols": summary})
        atomic_write_text(Path(out) / "results.md", "\n".join(lines) + "\n")
        for p, v in summary.items():
            C.plot_confusion(v["confusion"], v["classes"], Path(out) / f"confusion_{p.replace('+', '_')}.png",
                             f"{p}: {100 * v['accuracy_mean']:.1f} +- {100 * v['accuracy_std']:.1f} % over {seeds} seeds")


@cli.command()
@design_options
@click.option("--model", "model_file", type=click.Path(dir_okay=False), required=True, help="Saved model (.joblib).")
@click.option("--input", "input_file", type=click.Path(dir_okay=False), required=True,
              help="A CSV of samples (one per row, the authors' layout) or, with --tracks, a tracks CSV "
                   "from `whisker track`.")
@click.option("--tracks", is_flag=True, help="Input is a tracks CSV; consecutive frames form each sample.")
@click.option("--invalid", type=click.Choice(["error", "zero", "drop"]), default="error", show_default=True,
              help="Tracks only: whiskers the tracker lost: refuse, impute rest (0, 0), or drop the sample.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON lines instead of a table.")
def predict(design, model_file, input_file, tracks, invalid, as_json):
    """Predict the object for each sample; prints a header, label and probability per sample, and the
    count per predicted class. The model must have been trained for the design's whisker count."""
    import numpy as np

    from whisker.data import classify as C
    from whisker.data.dataset import DatasetError
    from whisker.data.dataset_files import read_rows, load_tracks

    try:
        bundle = C.load_model(model_file)
        if bundle["n_whiskers"] != design.whiskers.count:
            raise DatasetError(f"{model_file} was trained for {bundle['n_whiskers']} whiskers, the design has "
                               f"{design.whiskers.count}; give the matching --design/--set")
        if tracks:
            ds = load_tracks(input_file, "unknown", records_per_sample=bundle["n_records"], invalid=invalid)
            if ds.n_whiskers != bundle["n_whiskers"]:
                raise DatasetError(f"{input_file}: {ds.n_whiskers} whiskers, the model expects {bundle['n_whiskers']}")
            X, valid = ds.features(), ds.valid if invalid != "zero" else None
        else:
            X, valid = read_rows(Path(input_file)), None
        labels, proba = C.predict(bundle, X, valid)
    except (DatasetError, OSError) as err:
        fail(f"prediction refused: {err}")
    from collections import Counter

    if not as_json:
        click.echo("sample\tlabel\tprobability")
    for i, (lab, p) in enumerate(zip(labels, proba)):
        conf = float(np.max(p))
        if as_json:
            click.echo(json.dumps({"sample": i, "label": str(lab), "probability": round(conf, 4)}))
        else:
            click.echo(f"{i}\t{lab}\t{conf:.3f}")
    counts = Counter(str(x) for x in labels)
    click.echo(f"{len(labels)} sample(s): " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())), err=True)
