"""GMM/GMR vs summary-feature baseline on the HMP dataset, leave-one-volunteer-out.

Usage (from the repository root)::

    python3 benchmarks/har_hmp.py [--data ../shared/datasets/hmp] [--folds K] [--json]

Evaluates the seven HMP actions with at least 20 trials, splitting by volunteer (never by
trial), and prints accuracy and macro F1 of both methods plus the streaming check (recognition
delay after the end of a replayed trial, and speed relative to real time). The dataset is
research-use only and is read in place; nothing is copied. Exits 0 with a message when absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from flexhrc.perception.human import (  # noqa: E402
    HMP_SEVEN,
    GMMGMRRecognizer,
    OnlineRecognizer,
    load_dataset,
)
from flexhrc.perception.human.evaluation import (  # noqa: E402
    SummaryFeatureBaseline,
    classification_report,
    cross_validate,
    volunteer_folds,
)


def streaming_check(trials, n_folds, max_trials_per_fold: int = 6, seed: int = 0):
    """Replay held-out trials (with 3 s of stillness after) through the online recogniser."""
    rng = np.random.default_rng(seed)
    delays, correct, total, signal_s, cpu_s, others = [], 0, 0, 0.0, 0.0, 0
    for fold in volunteer_folds(trials, n_folds):
        train = [t for t in trials if t.volunteer not in fold]
        test = [t for t in trials if t.volunteer in fold]
        rec = GMMGMRRecognizer().fit(train)
        pick = rng.choice(len(test), min(max_trials_per_fold, len(test)), replace=False)
        for i in pick:
            t = test[i]
            still = np.repeat(t.samples[-1:], int(3 * t.rate_hz), axis=0)
            stream = np.vstack([t.samples, still])
            online = OnlineRecognizer(rec)
            c0 = time.process_time()
            found = online.replay(stream)
            cpu_s += time.process_time() - c0
            signal_s += len(stream) / t.rate_hz
            total += 1
            hits = [r for r in found if r.name == t.action]
            others += len(found) - len(hits)
            if hits:
                correct += 1
                first = min(hits, key=lambda r: r.t_end)
                delays.append(first.t_end - t.duration_s)
    return {
        "replayed_trials": total,
        "recognised_fraction": round(correct / total, 4) if total else 0.0,
        "other_actions_reported": others,
        "delay_after_end_s_median": round(float(np.median(delays)), 3) if delays else None,
        "delay_after_end_s_max": round(float(np.max(delays)), 3) if delays else None,
        "speed_x_realtime": round(signal_s / cpu_s, 1) if cpu_s else None,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(REPO.parent / "shared" / "datasets" / "hmp"))
    ap.add_argument("--folds", type=int, default=None, help="k folds by volunteer (default LOVO)")
    ap.add_argument("--no-stream", action="store_true", help="skip the streaming check")
    ap.add_argument("--no-baseline", action="store_true", help="skip the baseline")
    ap.add_argument(
        "--duration-weight", type=float, default=0.1, help="0: template match only (ablation)"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not Path(args.data).is_dir():
        print(f"HMP dataset not found at {args.data}; nothing to do", file=sys.stderr)
        return 0
    trials = load_dataset(args.data, actions=HMP_SEVEN)
    log = (lambda m: print(m, file=sys.stderr)) if args.json else print
    results = {}
    methods = [("gmm_gmr", lambda: GMMGMRRecognizer(duration_weight=args.duration_weight))]
    if not args.no_baseline:
        methods.append(("baseline_rf", SummaryFeatureBaseline))
    for name, make in methods:
        t0 = time.perf_counter()
        y_true, y_pred = cross_validate(trials, make, args.folds)
        rep = classification_report(y_true, y_pred, labels=sorted(HMP_SEVEN))
        rep["seconds"] = round(time.perf_counter() - t0, 1)
        results[name] = rep
        log(f"{name}: accuracy {rep['accuracy']:.3f}  macro F1 {rep['macro_f1']:.3f}")
    split = "leave-one-volunteer-out" if args.folds is None else f"{args.folds} folds by volunteer"
    out = {"split": split, "n_trials": len(trials), **results}
    if not args.no_stream:
        out["streaming"] = streaming_check(trials, args.folds)
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        print()
        return 0
    print(f"\nHMP, 7 actions, {len(trials)} trials, {split}\n")
    print("| method | accuracy | macro F1 |")
    print("|---|---|---|")
    print(
        f"| GMM/GMR (flexhrc) | {results['gmm_gmr']['accuracy']:.3f} | "
        f"{results['gmm_gmr']['macro_f1']:.3f} |"
    )
    if "baseline_rf" in results:
        b = results["baseline_rf"]
        print(
            f"| baseline: random forest on summary features | {b['accuracy']:.3f} | "
            f"{b['macro_f1']:.3f} |"
        )
    print("\nper-class recall (GMM/GMR):")
    for lab, pc in results["gmm_gmr"]["per_class"].items():
        print(f"  {lab:14s} P={pc['precision']:.2f} R={pc['recall']:.2f} n={pc['support']}")
    if "streaming" in out:
        print("\nstreaming:", json.dumps(out["streaming"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
