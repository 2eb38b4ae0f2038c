"""Classification benchmark: the paper's MLP on the authors' real data, honestly evaluated, and what
accuracy costs in time.

Needs the authors' data through WHISKER_PEER_DATA (skips with a message otherwise).

1. Protocols: the paper's configuration (32 ReLU, Adam lr 0.01, 10 epochs, batch 16, inputs / 229,
   7:3) under every split protocol of whisker.data.classify, on the paper's 5 objects and on all 10,
   mean +- sample std over 10 seeds (seed = split and initialisation), next to the paper's 99.17 %.
   The summed confusion matrices of the headline protocols go to docs/images/confusion_*.png.
2. Cost: hidden size x epochs against accuracy and training time (protocol "trial": whole trials
   held out, no rotation; and four points with rotation augmentation, "trial+rot"), 10 objects,
   3 seeds each.
3. Other models side by side on the same leak-free splits (principle 1): 1-nearest-neighbour,
   logistic regression, the paper's MLP and a larger MLP; fit time and inference time per sample
   (best of 5: one batch of all test samples / n, and one single-sample call).

4. The rotation pairing on simulated data: the simulator's classification scene (whisker.sim,
   software/whisker/sim/scenes/classification.toml: the sensor itself turned 0..300 deg in 60 deg
   steps, 5 trials each) gives samples whose sensor rotation is known; holding out whole rotations
   (`pose`) and augmenting with the design's sense vs the opposite sense shows which pairing of
   index shift and vector rotation is physical. Skipped if the simulator is not installed.

5. Beyond the paper (issue 31): the models of whisker.data.models (polar features + SVM / extra trees /
   gradient boosting, cyclic-shift-invariant DFT features + SVM) beside the paper's MLP and the MLP
   trained with rotated copies, whole trials and unseen orientations held out, 5 and 10 objects,
   10 seeds (joblib over the fits); accuracy, training time, inference time per sample.
6. Why rotated copies hurt on the real data: whisker.data.symmetry's pairing table (every index shift,
   both senses, every roll of the 4 approach directions) and the contact pattern.
7. Why whole held-out trials stop near 95 % (issue 31 asks 97 %): accuracy of every (object, trial)
   when it is held out; the trials no model recognises, trained on all the other 48 trials, with
   every feature family and a soft-voting ensemble; and the ceiling those trials put on the mean.

`python bench_classify.py --reuse` keeps sections 1-4 from their CSVs; `--reuse-beyond` also keeps
section 5 (classify_beyond.csv) (classify_protocols.csv,
classify.csv, classify_models.csv, classify_sim.csv) and recomputes 5-6.

Writes benchmarks/results/classify.md, classify_beyond.csv, classify_pairing.csv, classify.csv (the cost grid), classify_protocols.csv,
classify_confusion.json (summed confusion matrices), classify_models.csv, classify_sim.csv and
classify.png.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

from common import best_time_s, machine_line, markdown_table, save_figure, write_csv, write_text  # noqa: E402
from whisker.data import classify as C  # noqa: E402
from whisker.data.dataset import PAPER_OBJECTS  # noqa: E402
from whisker.data.dataset_files import load_peer  # noqa: E402

DOCS_IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"
SEEDS = range(10)
GRID_SEEDS = range(3)
HIDDEN = [8, 16, 32, 64, 128]
EPOCHS = [5, 10, 20, 40]
ROT_GRID = [(8, 10), (32, 10), (128, 10), (32, 40)]


def protocol_table(peer):
    rows, summaries = [], {}
    for label, ds in (("paper's 5", peer.select(PAPER_OBJECTS)), ("all 10", peer)):
        s = C.summarize(C.study(ds, C.PROTOCOLS, SEEDS, progress=True))
        summaries[label] = s
        for p, v in s.items():
            rows.append({"objects": label, "protocol": p, "accuracy_mean_pct": 100 * v["accuracy_mean"],
                         "accuracy_std_pct": 100 * v["accuracy_std"], "accuracy_min_pct": 100 * v["accuracy_min"],
                         "n_train": v["n_train"], "n_test": v["n_test"], "train_s": v["train_s_mean"]})
    return rows, summaries


def cost_grid(peer):
    rows = []
    jobs = [("trial", h, e) for h in HIDDEN for e in EPOCHS] + [("trial+rot", h, e) for h, e in ROT_GRID]
    from tqdm import tqdm

    for protocol, h, e in tqdm(jobs, desc="cost grid", unit="config"):
        rs = [C.run(peer, protocol, s, hidden=h, epochs=e) for s in GRID_SEEDS]
        acc = np.array([r.accuracy for r in rs])
        rows.append({"protocol": protocol, "hidden": h, "epochs": e, "accuracy_mean_pct": 100 * acc.mean(),
                     "accuracy_std_pct": 100 * acc.std(ddof=1), "train_s": float(np.mean([r.train_s for r in rs])),
                     "predict_us_per_sample": 1e6 * float(np.mean([r.predict_s_per_sample for r in rs])),
                     "n_train": rs[0].n_train})
    return rows


def model_table(peer):
    from sklearn.linear_model import LogisticRegression
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer

    scale = FunctionTransformer(C._scale, kw_args={"scale": C.PEER_SCALE})
    models = {
        "1-nearest-neighbour": lambda s: make_pipeline(scale, KNeighborsClassifier(1)),
        "logistic regression": lambda s: make_pipeline(scale, LogisticRegression(max_iter=2000, C=10.0)),
        "MLP 32, 10 epochs (paper)": lambda s: C.make_classifier(seed=s),
        "MLP 128, 40 epochs": lambda s: C.make_classifier(hidden=128, epochs=40, seed=s),
    }
    rows = []
    for protocol in ("random", "trial", "pose"):
        for name, make in models.items():
            acc, fit_s, batch_us, single_us = [], [], [], []
            for seed in range(5):
                train, test = C.split(peer, protocol, seed)
                m = make(seed)
                t = time.perf_counter()
                C.fit_quiet(m, train.features(), train.y)
                fit_s.append(time.perf_counter() - t)
                acc.append(np.mean(m.predict(test.features()) == test.y))
                if seed == 0:
                    Xt = test.features()
                    batch_us.append(1e6 * best_time_s(lambda: m.predict(Xt)) / len(Xt))
                    single_us.append(1e6 * best_time_s(lambda: m.predict(Xt[:1]), number=20))
            rows.append({"protocol": protocol, "model": name, "accuracy_mean_pct": 100 * np.mean(acc),
                         "accuracy_std_pct": 100 * np.std(acc, ddof=1), "fit_s": float(np.mean(fit_s)),
                         "batch_us_per_sample": batch_us[0], "single_call_us": single_us[0]})
    return rows


def sim_sense_check():
    """Accuracy on the simulated dataset with the design's sense and the opposite one (10 seeds)."""
    import dataclasses
    import subprocess
    import tempfile

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    try:
        import whisker.sim  # noqa: F401
    except ImportError as err:
        print(f"bench_classify: simulator not available ({err}); section 4 skipped")
        return []
    from whisker.data.dataset_files import load_csv_folder
    from whisker.design import default_design

    scene = Path(__file__).resolve().parents[1] / "software" / "whisker" / "sim" / "scenes" / "classification.toml"
    trials = tomllib.loads(scene.read_text())["experiment"]["trials"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        res = subprocess.run([sys.executable, "-m", "whisker.cli", "sim", str(scene), "--out", tmp, "-q"],
                             capture_output=True, text=True, timeout=1200)
        if res.returncode:
            print(f"bench_classify: simulation failed, section 4 skipped: {res.stderr.strip()[-300:]}")
            return []
        ds = load_csv_folder(Path(tmp) / "dataset", trials_per_pose=trials, design=default_design())
    for sense, name in ((ds.sense, "design's sense"), (-ds.sense, "opposite sense")):
        d = dataclasses.replace(ds, sense=sense)
        protocols = ("random", "pose", "random+rot", "trial+rot", "pose+rot") if sense == ds.sense else \
            ("random+rot", "trial+rot", "pose+rot")
        for p, v in C.summarize(C.study(d, protocols, SEEDS)).items():
            rows.append({"rotation_pairing": name if p.endswith("+rot") else "no augmentation", "protocol": p,
                         "accuracy_mean_pct": 100 * v["accuracy_mean"], "accuracy_std_pct": 100 * v["accuracy_std"],
                         "n_train": v["n_train"], "n_test": v["n_test"]})
    return rows


BEYOND = [("mlp", "MLP 32, 10 epochs (paper)", {}), ("mlp", "MLP 128, 40 epochs", {"hidden": 128, "epochs": 40}),
          ("svc", "polar features + RBF SVM", {}), ("trees", "polar features + extra trees", {}),
          ("hgb", "polar features + gradient boosting", {}), ("dft-svc", "cyclic DFT features + RBF SVM", {})]


def _rot_trained_mlp(ds, protocol, seed):
    """The paper's MLP trained on the training side plus its rotated copies, tested as recorded."""
    from whisker.data.dataset import augment_rotations

    train, test = C.split(ds, protocol, seed)
    train = augment_rotations(train)
    m = C.make_classifier(seed=seed)
    t = time.perf_counter()
    C.fit_quiet(m, train.features(), train.y)
    fit = time.perf_counter() - t
    t = time.perf_counter()
    pred = m.predict(test.features())
    return float(np.mean(pred == test.y)), fit, (time.perf_counter() - t) / len(test)


def beyond_table(peer, n_jobs=2):
    from joblib import Parallel, delayed

    rows = []
    for label, ds in (("paper's 5", peer.select(PAPER_OBJECTS)), ("all 10", peer)):
        for kind, name, params in BEYOND:
            rs = C.study(ds, ("trial", "pose"), SEEDS, progress=True, n_jobs=n_jobs, kind=kind, **params)
            for p in ("trial", "pose"):
                sub = [r for r in rs if r.protocol == p]
                acc = np.array([r.accuracy for r in sub])
                rows.append({"objects": label, "protocol": p, "model": name, "accuracy_mean_pct": 100 * acc.mean(),
                             "accuracy_std_pct": 100 * acc.std(ddof=1), "accuracy_min_pct": 100 * acc.min(),
                             "fit_s": float(np.mean([r.train_s for r in sub])),
                             "predict_us_per_sample": 1e6 * float(np.mean([r.predict_s_per_sample for r in sub]))})
        for p in ("trial", "pose"):
            out = Parallel(n_jobs=n_jobs)(delayed(_rot_trained_mlp)(ds, p, s) for s in SEEDS)
            acc = np.array([o[0] for o in out])
            rows.append({"objects": label, "protocol": p, "model": "MLP 32 trained with rotated copies, tested as recorded",
                         "accuracy_mean_pct": 100 * acc.mean(), "accuracy_std_pct": 100 * acc.std(ddof=1),
                         "accuracy_min_pct": 100 * acc.min(), "fit_s": float(np.mean([o[1] for o in out])),
                         "predict_us_per_sample": 1e6 * float(np.mean([o[2] for o in out]))})
    return rows


def pairing_rows(peer):
    from whisker.data.symmetry import contact_pattern, pairing_table

    table = pairing_table(peer)
    base, rest = table[0], sorted(table[1:], key=lambda r: r["median_nn_px"])
    pattern = contact_pattern(peer)
    pat_rows = [{"record": f"{r} (direction {r // 2}, {'near' if r % 2 else 'far'})",
                 **{f"w{w}": f"{100 * pattern[r, w]:.0f}" for w in range(peer.n_whiskers)}}
                for r in range(peer.n_records)]
    return base, rest, pat_rows


def _odd_features():
    """Feature variants for section 7 (flat rows -> features), each a plain function of one sample."""
    def norm_polar(X):                      # magnitudes relative to the sample's own mean (force-free)
        S = np.asarray(X, float).reshape(len(X), 8, 8, 2)
        mag = np.linalg.norm(S, axis=-1)
        lm = np.log1p(mag)
        lm = lm - lm.mean(axis=(1, 2), keepdims=True)
        return np.concatenate([lm.reshape(len(S), -1), (S / np.maximum(mag, 1.0)[..., None]).reshape(len(S), -1)], 1)

    def directions(X):                      # contact directions only
        S = np.asarray(X, float).reshape(len(X), 8, 8, 2)
        return (S / np.maximum(np.linalg.norm(S, axis=-1), 1.0)[..., None]).reshape(len(S), -1)

    def temporal(X):                        # over the 8 records: share touched, peak, mean direction
        S = np.asarray(X, float).reshape(len(X), 8, 8, 2)
        mag = np.linalg.norm(S, axis=-1)
        return np.concatenate([(mag > 2).mean(1), np.log1p(mag).max(1),
                               (S / np.maximum(mag, 1.0)[..., None]).mean(1).reshape(len(S), -1)], 1)
    return {"magnitudes normalised per sample": norm_polar, "directions only": directions,
            "temporal summary of the 8 records": temporal}


def _beyond_acc(beyond, best_by) -> str:
    """Section 5's 10-object trial accuracy of the model(s) named in best_by, as text."""
    names = sorted(set(best_by.values()))
    out = []
    for n in names:
        row = [r for r in beyond if r["objects"] == "all 10" and r["protocol"] == "trial" and r["model"] == n]
        out.append(f"{row[0]['accuracy_mean_pct']:.1f} % ({n})" if row else f"- ({n}: not in section 5)")
    return ", ".join(out)


def trial_ceiling(peer):
    """Section 7: per-trial held-out accuracy (polar SVM, the 10 trial splits), the outlier trials
    trained on everything else, and the mean accuracy those trials allow."""
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer, StandardScaler
    from sklearn.svm import SVC

    from whisker.data.models import make_model

    per, splits = {}, []
    for seed in SEEDS:
        train, test = C.split(peer, "trial", seed)
        m = make_model("svc", seed=seed)
        C.fit_quiet(m, train.features(), train.y)
        pred = m.predict(test.features())
        splits.append((test, pred))
        for o in np.unique(test.y):
            for t in np.unique(test.trial[test.y == o]):
                k = (test.y == o) & (test.trial == t)
                per.setdefault((str(o), int(t)), []).append(float(np.mean(pred[k] == o)))
    trial_rows = [{"object": o, "trial": t, "times_held_out": len(v), "accuracy_pct": 100 * float(np.mean(v))}
                  for (o, t), v in sorted(per.items())]
    odd = [(r["object"], r["trial"]) for r in trial_rows if r["accuracy_pct"] < 50]
    is_odd = np.zeros(len(peer), bool)
    for o, t in odd:
        is_odd |= (peer.y == o) & (peer.trial == t)
    rest = peer.subset(np.flatnonzero(~is_odd))
    models = {"polar features + RBF SVM": lambda: make_model("svc", seed=0),
              "polar features + extra trees": lambda: make_model("trees", seed=0),
              "cyclic DFT features + RBF SVM": lambda: make_model("dft-svc", seed=0),
              "MLP 128, 40 epochs": lambda: make_model("mlp", seed=0, hidden=128, epochs=40)}
    for name, f in _odd_features().items():
        models[name + " + RBF SVM"] = (lambda f=f: make_pipeline(FunctionTransformer(f), StandardScaler(),
                                                                  SVC(C=10.0, gamma="scale")))
    odd_rows, probs = [], []
    F = peer.features()
    for name, make in models.items():
        m = make()
        C.fit_quiet(m, rest.features(), rest.y)
        row = {"model (trained on the other 48 trials)": name}
        for o, t in odd:
            k = (peer.y == o) & (peer.trial == t)
            row[f"{o} trial {t} %"] = 100 * float(np.mean(m.predict(F[k]) == o))
        if name in ("polar features + RBF SVM", "polar features + extra trees", "MLP 128, 40 epochs"):
            probs.append({(o, t): m.predict_proba(F[(peer.y == o) & (peer.trial == t)]) for o, t in odd})
            classes = np.asarray(m.classes_)
        odd_rows.append(row)
    vote = {"model (trained on the other 48 trials)": "soft vote: SVM + extra trees + MLP 128"}
    for o, t in odd:
        P = sum(p[(o, t)] for p in probs)
        vote[f"{o} trial {t} %"] = 100 * float(np.mean(classes[P.argmax(1)] == o))
    odd_rows.append(vote)
    # the ceiling: every other test sample right, the odd trials at their best leave-out accuracy
    best_odd = {(o, t): max(r[f"{o} trial {t} %"] for r in odd_rows) / 100 for o, t in odd}
    ceil, without = [], []
    for test, pred in splits:
        wrong = sum((1 - best_odd[(o, t)]) * np.sum((test.y == o) & (test.trial == t)) for o, t in odd)
        ceil.append(1 - wrong / len(test))
        k = np.ones(len(test), bool)
        for o, t in odd:
            k &= ~((test.y == o) & (test.trial == t))
        without.append(float(np.mean(pred[k] == test.y[k])))
    acc = [float(np.mean(pred == test.y)) for test, pred in splits]
    key = "model (trained on the other 48 trials)"
    best_by = {f"{o} trial {t}": max(odd_rows, key=lambda r: r[f"{o} trial {t} %"])[key] for o, t in odd}
    summary = {"odd": odd, "svm_mean": 100 * float(np.mean(acc)), "ceiling_mean": 100 * float(np.mean(ceil)),
               "without_mean": 100 * float(np.mean(without)), "best_by": best_by}
    return trial_rows, odd_rows, summary


def _read_csv(name):
    import csv

    from common import RESULTS

    def num(v):
        try:
            return int(v)
        except ValueError:
            try:
                return float(v)
            except ValueError:
                return v

    with open(RESULTS / name, newline="") as fh:
        return [{k: num(v) for k, v in r.items()} for r in csv.DictReader(fh)]


def plot(grid, prot_rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.6))
    for protocol, marker in (("trial", "o"), ("trial+rot", "s")):
        for e in sorted({r["epochs"] for r in grid}):
            pts = [r for r in grid if r["protocol"] == protocol and r["epochs"] == e]
            if not pts:
                continue
            a.errorbar([r["train_s"] for r in pts], [r["accuracy_mean_pct"] for r in pts],
                       yerr=[r["accuracy_std_pct"] for r in pts], marker=marker, ls="-", capsize=2,
                       label=f"{protocol}, {e} epochs")
            for r in pts:
                a.annotate(str(r["hidden"]), (r["train_s"], r["accuracy_mean_pct"]), fontsize=6,
                           xytext=(2, 2), textcoords="offset points")
    a.set_xscale("log")
    a.set_xlabel("training time per fit (s, log)")
    a.set_ylabel("test accuracy (%), 10 objects")
    a.set_title("cost: hidden units (labels) x epochs, whole trials held out", fontsize=9)
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
    labels = list(C.PROTOCOLS)
    x = np.arange(len(labels))
    for i, obj in enumerate(("paper's 5", "all 10")):
        rs = {r["protocol"]: r for r in prot_rows if r["objects"] == obj}
        b.bar(x + (i - 0.5) * 0.38, [rs[p]["accuracy_mean_pct"] for p in labels], 0.38,
              yerr=[rs[p]["accuracy_std_pct"] for p in labels], capsize=2, label=obj)
    b.axhline(100 * C.PAPER_ACCURACY, color="k", ls="--", lw=1, label="paper 99.17 %")
    b.set_xticks(x, labels, rotation=20)
    b.set_ylim(40, 101)
    b.set_ylabel("test accuracy (%), mean +- std, 10 seeds")
    b.set_title("the paper's MLP under each split protocol", fontsize=9)
    b.legend(fontsize=7, loc="lower left")
    b.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    save_figure(fig, "classify.png")
    plt.close(fig)


def main() -> int:
    data = os.environ.get("WHISKER_PEER_DATA")
    if not data or not Path(data).is_dir():
        print("bench_classify: skipped, WHISKER_PEER_DATA is not set (the authors' data is not in the repository)")
        return 0
    peer = load_peer(data)
    t0 = time.perf_counter()
    if "--reuse" in sys.argv[1:]:
        prot_rows, grid = _read_csv("classify_protocols.csv"), _read_csv("classify.csv")
        models = _read_csv("classify_models.csv")
        sim_rows = _read_csv("classify_sim.csv") if (Path(__file__).parent / "results" / "classify_sim.csv").exists() else []
    else:
        prot_rows, summaries = protocol_table(peer)
        write_csv("classify_protocols.csv", prot_rows)
        from common import RESULTS
        from whisker.files import atomic_write_json

        atomic_write_json(RESULTS / "classify_confusion.json", summaries)
        print(markdown_table(prot_rows, ["objects", "protocol", "accuracy_mean_pct", "accuracy_std_pct", "n_train",
                                         "n_test"], {"accuracy_mean_pct": ".2f", "accuracy_std_pct": ".2f"}), flush=True)
        for obj, tag in (("paper's 5", "paper5"), ("all 10", "all10")):
            for p in ("paper", "random", "trial+rot", "pose"):
                v = summaries[obj][p]
                C.plot_confusion(v["confusion"], v["classes"], DOCS_IMAGES / f"confusion_{tag}_{p.replace('+', '_')}.png",
                                 f"{obj} objects, protocol {p}: {100 * v['accuracy_mean']:.1f} +- "
                                 f"{100 * v['accuracy_std']:.1f} % ({len(SEEDS)} seeds summed)")
        grid = cost_grid(peer)
        write_csv("classify.csv", grid)
        models = model_table(peer)
        sim_rows = sim_sense_check()
        if sim_rows:
            write_csv("classify_sim.csv", sim_rows)
        write_csv("classify_models.csv", models)
        plot(grid, prot_rows)
    base, pairings, pattern = pairing_rows(peer)
    write_csv("classify_pairing.csv", [base] + pairings)
    if "--reuse-beyond" in sys.argv[1:]:
        beyond = _read_csv("classify_beyond.csv")
    else:
        beyond = beyond_table(peer)
        write_csv("classify_beyond.csv", beyond)
    trial_rows, odd_rows, ceiling = trial_ceiling(peer)
    write_csv("classify_trials.csv", trial_rows)
    print(ceiling, flush=True)
    best = {(o, p): max((r for r in beyond if r["objects"] == o and r["protocol"] == p),
                        key=lambda r: r["accuracy_mean_pct"]) for o in ("paper's 5", "all 10") for p in ("trial", "pose")}
    f1 = {"accuracy_mean_pct": ".2f", "accuracy_std_pct": ".2f", "accuracy_min_pct": ".2f", "train_s": ".2f",
          "predict_us_per_sample": ".1f", "fit_s": ".2f", "batch_us_per_sample": ".1f", "single_call_us": ".0f"}
    paper_cfg = [r for r in grid if r["protocol"] == "trial" and r["hidden"] == 32 and r["epochs"] == 10][0]
    text = f"""# Classification benchmark (the authors' real data)

Machine: {machine_line()}; whole run {time.perf_counter() - t0:.0f} s. Data: {peer.source}
(10 objects x 180 samples x 8 records x 8 whiskers x (dx, dy) px). Model: scikit-learn MLPClassifier,
the paper's configuration unless stated (32 ReLU, Adam lr 0.01, 10 epochs, batch 16, inputs / 229).
Protocols: see docs/classification.md. The paper reports 99.17 % on its 5 objects.

## 1. Accuracy under each split protocol ({len(SEEDS)} seeds, mean +- sample std)

{markdown_table(prot_rows, ["objects", "protocol", "accuracy_mean_pct", "accuracy_std_pct", "accuracy_min_pct", "n_train", "n_test", "train_s"], f1)}

## 2. What accuracy costs: hidden units x epochs (10 objects, {len(GRID_SEEDS)} seeds)

Training time is per fit on this machine (shared, 2 cores); inference is per sample in one batch.
The paper's configuration (32 units, 10 epochs), whole trials held out: {paper_cfg['accuracy_mean_pct']:.1f} %
in {paper_cfg['train_s']:.2f} s.

{markdown_table(grid, ["protocol", "hidden", "epochs", "accuracy_mean_pct", "accuracy_std_pct", "train_s", "predict_us_per_sample", "n_train"], f1)}

## 3. Other models on the same splits (10 objects, 5 seeds)

Inference: `batch_us_per_sample` = best-of-5 time of predicting all test samples at once / n;
`single_call_us` = one sample per call (scikit-learn's per-call overhead dominates).

{markdown_table(models, ["protocol", "model", "accuracy_mean_pct", "accuracy_std_pct", "fit_s", "batch_us_per_sample", "single_call_us"], f1)}

## 4. Rotation pairing on the simulator's dataset (5 objects, sensor turned 0..300 deg, 10 seeds)

`pose` holds out whole sensor rotations: without augmentation the test rotations are unseen; the
rotation augmentation must map trained rotations onto them, which works only with the physical pairing
of index shift and vector rotation (`sense` from the design's camera model, `whisker.data.dataset_files.design_sense`).

{markdown_table(sim_rows, ["rotation_pairing", "protocol", "accuracy_mean_pct", "accuracy_std_pct", "n_train", "n_test"], f1) if sim_rows else "(skipped: simulator not available)"}

## 5. Beyond the paper: models on the leak-free splits ({len(SEEDS)} seeds, joblib over the fits)

Whole trials held out (`trial`) and unseen orientations held out (`pose`). `fit_s` = training time
per fit, `predict_us_per_sample` = predicting the whole test side in one call / n (2 workers on this
shared machine). Best on 10 objects: {best[("all 10", "trial")]["model"]} {best[("all 10", "trial")]["accuracy_mean_pct"]:.2f} % (trial),
{best[("all 10", "pose")]["model"]} {best[("all 10", "pose")]["accuracy_mean_pct"]:.2f} % (pose).

{markdown_table(beyond, ["objects", "protocol", "model", "accuracy_mean_pct", "accuracy_std_pct", "accuracy_min_pct", "fit_s", "predict_us_per_sample"], f1)}

## 6. Why rotated copies hurt on the real data (whisker.data.symmetry)

Each recorded sample turned by k whisker spacings (sense +1 / -1), its 4 approach directions rolled
by `record_roll`: median distance to the nearest recorded row, and how often that row is the same
object (chance 10 %). The recorded rows themselves (k = 0, nearest other row) first, then the 8 closest
of the {len(pairings)} pairings:

{markdown_table([base] + pairings[:8], ["k", "sense", "record_roll", "median_nn_px", "same_object_frac"], {"median_nn_px": ".1f", "same_object_frac": ".3f"})}

Contact pattern: % of samples in which each record moves each whisker by more than 2 px (a setup
symmetric under the array's turns would move a set shifted by 2 whiskers from one direction to the next):

{markdown_table(pattern, ["record"] + [f"w{w}" for w in range(peer.n_whiskers)])}

## 7. Why whole held-out trials stop near 95 % (the issue asks 97 %)

Each object was recorded in 5 trials of 36 orientations; the `trial` protocol holds out 2 of them per
object. Accuracy of each (object, trial) over the splits that held it out (polar features + RBF SVM,
the {len(SEEDS)} trial splits of section 5), the trials below 97 %:

{markdown_table([r for r in trial_rows if r["accuracy_pct"] < 97], ["object", "trial", "times_held_out", "accuracy_pct"], {"accuracy_pct": ".1f"})}

{len(ceiling["odd"])} trials ({", ".join(f"{o} {t}" for o, t in ceiling["odd"])}) are not recognised even when every
other trial of every object is in the training set, whatever the features (per-sample magnitude
normalisation, directions only, a temporal summary of the 8 records, the cyclic-invariant DFT) or the
model (SVM, trees, MLP, their soft-voting ensemble):

{markdown_table(odd_rows, list(odd_rows[0]), {k: ".1f" for k in odd_rows[0] if k.endswith("%")})}

Their samples resemble another object's more than their own object's other trials (the object sat
differently in that trial: e.g. the cherry's trial 4 moves the whiskers more than its other four). Even
with every other held-out sample right and these trials at their best leave-out accuracy above
({"; ".join(f"{k}: {v}" for k, v in ceiling["best_by"].items())}), the mean over the {len(SEEDS)} splits could
reach at most **{ceiling["ceiling_mean"]:.2f} %**. The SVM reaches {ceiling["svm_mean"]:.2f} % with them and **{ceiling["without_mean"]:.2f} %** on the
other held-out trials; with those errors as well, about {ceiling["ceiling_mean"] - (100 - ceiling["without_mean"]):.1f} % is within reach, and only by one model
that is as good as the SVM on the ordinary trials and as good as the best above on these two. None of
the tried ones is: the model best on them holds out whole trials at {_beyond_acc(beyond, ceiling["best_by"])} (section 5), and the
soft-voting ensemble loses on them what the MLP gains. 97 % on whole held-out trials needs recordings that
cover how an object can sit (more trials per object), not another model.

![accuracy vs cost, protocols](classify.png)
"""
    write_text("classify.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
