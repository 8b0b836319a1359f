"""Reproduce the FlexHRC+ paper's Fig. 6 experiment on the authors' own graph files, and
measure flexhrc against the public C++ ANDOR side by side (issue 9, item 6).

Parity (first, unless ``--no-parity``): the C++ library built with ``g++ -O2``
(``../shared/anchors/andor-cpp/build.sh``; built on first use into ``~/.cache/flexhrc-cppref``)
and flexhrc run on the same files with the same random-client protocol, alternating, in one
run: per seed one fresh C++ process and one fresh ``python -m flexhrc graph play --json``
process, so flexhrc's offline time is a cold first call as ``graph play`` reports it. Both
sides time themselves from inside (process start-up is excluded on both). Medians over 5 seeds;
printed with the ratio flexhrc / C++ and the targets of issue 9. Without the C++ binary (or
``../shared``) the parity table says so and is skipped. flexhrc reads the ANDOR text files with
its compiled common case when the install has built it (the table says which reader ran);
``--pure-python`` measures the pure-Python reader instead.

For every file: offline time (load + validate + build, including the initial cost computation)
and online time per query, medians over 10 random traversals (the authors' random test client:
query 0 is empty, each later query reports one element drawn uniformly from the previous answer's
feasible nodes and hyper-arcs). Printed as a table beside the public C++ implementation (measured
on this kind of machine, ``../shared/anchors/andor-cpp-reference.md``) and the paper's published
figures, with the ratio and the target of issue #2; plotted to PNG on log scales.

Fig. 6, the result (``--enumerate``, issue 21 item 7): the paper's offline phase enumerates every
cooperation path, so its single-layer curves grow exponentially with the number of legs while
the hierarchical one does not. ``--enumerate`` times, for the single-layer FOL, the standard
(propositional) and the hierarchical table graphs of 1..``--legs`` legs, three methods side by
side in one run, each run in a fresh process capped at ``--time-limit`` seconds (and
``--memory-limit`` GiB): flexhrc's path enumeration (its reference mode, ``graph suggest
--exact``: load, build, then every cooperation path of every instance enumerated and costed),
flexhrc's dynamic programming (``graph play``, the default) and the C++ ANDOR (``-O2``, path
enumeration, the paper's code). Offline time and online time per query (enumeration: the median
of its first 3 queries, each one re-enumerating; the others: the median of a whole random
traversal), medians of up to ``--seeds`` seeds (fewer once a point has used its time limit); a
run past the cap is shown as such and the larger graphs of that line are not run. Prints both
tables and the growth from 4 to 8 legs, and draws the paper's layout (time against legs, log
scale, offline above, online below, one line per representation and method) to ``--out``.

    python benchmarks/andor_paper.py [--anchors DIR] [--runs 10] [--out out/andor_paper.png]
                                     [--json out/andor_paper.json] [--seeds 5]
                                     [--cpp PATH] [--no-parity] [--parity-only]
                                     [--pure-python]
    python benchmarks/andor_paper.py --enumerate [--legs 9] [--time-limit 60] [--seeds 5]
                                     [--memory-limit 3] [--no-cpp] [--out out/andor_fig6.png]

Needs ``../shared/anchors/andor-graphs`` (or ``--anchors``); the plot needs matplotlib.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexhrc.representation import load  # noqa: E402
from flexhrc.representation.online import OnlineGraph  # noqa: E402
from flexhrc.representation.play import play  # noqa: E402

DEFAULT_ANCHORS = ROOT.parent / "shared" / "anchors" / "andor-graphs"
CPP_SOURCES = ROOT.parent / "shared" / "anchors" / "andor-cpp"
CPP_BINARY = Path.home() / ".cache" / "flexhrc-cppref" / "andor_bench"

# Issue 9, item 6: (label, file under the anchors, metric, target ratio flexhrc / C++).
PARITY: list[tuple[str, str, str, float]] = [
    ("kitchen", "TRO-IKEAKitchenAssembly/KitchenAssembly.txt", "offline_s", 1.5),
    ("kitchen", "TRO-IKEAKitchenAssembly/KitchenAssembly.txt", "online_s_per_query_median", 1.0),
    (
        "hierarchical 10 legs",
        "TRO-TableAssembly/10Leg/TableAssembly_hierarchical.txt",
        "online_s_per_query_median",
        3.0,
    ),
    ("ball FOL (7 nodes)", "TRO-BallBoxPlacement/FOL_BallPlacment.txt", "offline_s", 5.0),
]
METRIC = {"offline_s": "offline", "online_s_per_query_median": "per query"}

# C++ ANDOR (commit 1499895, g++ -O2, this kind of machine): offline s, per-query median s.
# From ../shared/anchors/andor-cpp-reference.md. None: not measured / did not finish.
CPP: dict[str, tuple[float | None, float | None]] = {
    "FOL 1 leg": (3.8e-5, 1.8e-6),
    "FOL 4 legs": (4.4e-4, 1.2e-5),
    "FOL 5 legs": (2.6e-3, 4.5e-5),
    "FOL 6 legs": (0.034, 2.5e-4),
    "FOL 7 legs": (0.447, 1.2e-3),
    "FOL 8 legs": (8.31, 0.016),
    "FOL 9 legs": (215.6, 0.079),
    "FOL 10 legs": (5400.0, None),  # not finished; ~1.5 h extrapolated
    "hierarchical 1 leg": (4.4e-5, 1.9e-6),
    "hierarchical 5 legs": (9.1e-5, 1.6e-6),
    "hierarchical 9 legs": (1.5e-4, 1.5e-6),
    "hierarchical 10 legs": (1.6e-4, 1.5e-6),
    "PL 3 legs": (5.2e-4, 8.9e-6),
    "PL 4 legs": (0.056, 1.6e-4),
    "PL 5 legs": (26.6, 0.018),
    "kitchen": (1.7e-3, 1.3e-5),
    "ball FOL": (2.4e-5, 1.3e-6),
    "ball PL": (3.5e-5, 2.7e-6),
}
# The paper's own figures (i7-4790, ROS): offline s, online total s.
PAPER: dict[str, tuple[float, float]] = {
    "hierarchical 9 legs": (7.6e-4, 1.9e-3),
    "FOL 9 legs": (1.98e3, 17.0),
    "PL 5 legs": (349.0, 3.1),
    "kitchen": (5.1e-3, 0.146),
}
# Targets of issue #2: offline s, per-query s.
TARGETS: dict[str, tuple[float | None, float | None]] = {
    "kitchen": (10e-3, 50e-6),
    "hierarchical 10 legs": (None, 20e-6),
    "FOL 9 legs": (5e-3, None),
    "FOL 10 legs": (5e-3, 50e-6),
    "PL 5 legs": (20e-3, 100e-6),
}


def corpus(anchors: Path) -> list[tuple[str, Path]]:
    files: list[tuple[str, Path]] = []
    for n in range(1, 11):
        files.append(
            (
                f"FOL {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-TableAssembly/{n}Leg/TableAssembly.txt",
            )
        )
    for n in range(1, 11):
        files.append(
            (
                f"hierarchical {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-TableAssembly/{n}Leg/TableAssembly_hierarchical.txt",
            )
        )
    for n in range(1, 6):
        files.append(
            (
                f"PL {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-PL_FOL-TableAssembly/{n}Leg/TableAssemblyPL.txt",
            )
        )
    files.append(("kitchen", anchors / "TRO-IKEAKitchenAssembly/KitchenAssembly.txt"))
    files.append(("ball FOL", anchors / "TRO-BallBoxPlacement/FOL_BallPlacment.txt"))
    files.append(("ball PL", anchors / "TRO-BallBoxPlacement/PL_BallPlacement.txt"))
    return [(label, p) for label, p in files if p.is_file()]


@dataclass
class Row:
    label: str
    size: int  # instantiated nodes + hyper-arcs
    queries: int
    offline_s: float
    online_total_s: float
    per_query_s: float


def measure(label: str, path: Path, runs: int) -> Row:
    offline, totals, per_query, queries = [], [], [], []
    for seed in range(runs):
        report = play(path, "random", seed)
        if report.outcome != "solved":
            raise SystemExit(f"{path}: random traversal {seed} ended {report.outcome}")
        offline.append(report.offline_s)
        totals.append(report.online_s_total)
        per_query.append(report.online_s_per_query_median)
        queries.append(report.queries)
    online = OnlineGraph(load(path))
    return Row(
        label,
        len(online.elements()),
        int(statistics.median(queries)),
        statistics.median(offline),
        statistics.median(totals),
        statistics.median(per_query),
    )


def fmt(x: float | None) -> str:
    if x is None:
        return "–"
    if x >= 1:
        return f"{x:.3g} s"
    if x >= 1e-3:
        return f"{x * 1e3:.3g} ms"
    return f"{x * 1e6:.3g} µs"


def ratio(ours: float, ref: float | None) -> str:
    if ref is None:
        return "–"
    r = ref / ours
    return f"{r:.3g}x faster" if r >= 1 else f"{1 / r:.3g}x slower"


def check(value: float, target: float | None) -> str:
    if target is None:
        return ""
    return f"{'PASS' if value <= target else 'FAIL'} (<= {fmt(target)})"


def slope(rows: list[Row]) -> float:
    """Least-squares slope of log(per-query time) against log(graph size)."""
    xs = [math.log(r.size) for r in rows]
    ys = [math.log(r.per_query_s) for r in rows]
    mx, my = statistics.mean(xs), statistics.mean(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum(
        (x - mx) ** 2 for x in xs
    )


def plot(rows: list[Row], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 6), sharey=False)
    labels = [r.label for r in rows]
    y = range(len(rows))
    for ax, title, ours, cpp_i in (
        (axes[0], "offline (load + build)", [r.offline_s for r in rows], 0),
        (axes[1], "online, per query (median)", [r.per_query_s for r in rows], 1),
    ):
        cpp = [CPP.get(r.label, (None, None))[cpp_i] for r in rows]
        ax.scatter(ours, y, marker="o", color="tab:blue", label="flexhrc (Python, DP)", zorder=3)
        ax.scatter(
            [c for c in cpp if c is not None],
            [i for i, c in zip(y, cpp, strict=True) if c is not None],
            marker="s",
            color="tab:red",
            label="C++ ANDOR -O2 (path enumeration)",
            zorder=3,
        )
        if cpp_i == 0:
            pts = [(PAPER[r.label][0], i) for i, r in zip(y, rows, strict=True) if r.label in PAPER]
            ax.scatter(
                *zip(*pts, strict=True), marker="^", color="tab:green", label="paper (Fig. 6)"
            )
        ax.set_xscale("log")
        ax.set_yticks(list(y))
        ax.set_yticklabels(labels if cpp_i == 0 else [])
        ax.invert_yaxis()
        ax.set_xlabel("seconds (log scale)")
        ax.set_title(title)
        ax.grid(True, axis="x", which="both", alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(
        "AND/OR graph engine on the FlexHRC+ authors' files (medians of random traversals)"
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


def find_cpp(explicit: Path | None, sources: Path = CPP_SOURCES) -> Path | None:
    """The C++ driver: --cpp, else the cache, else built from ../shared (g++ -O2)."""
    if explicit is not None:
        return explicit if explicit.is_file() else None
    if CPP_BINARY.is_file():
        return CPP_BINARY
    build = sources / "build.sh"
    if build.is_file() and shutil.which("g++"):
        print(f"building the C++ reference: {build}", file=sys.stderr, flush=True)
        proc = subprocess.run(["bash", str(build)], capture_output=True, text=True)
        if proc.returncode == 0 and CPP_BINARY.is_file():
            return CPP_BINARY
        print(f"C++ build failed: {proc.stderr.strip()[-400:]}", file=sys.stderr)
    return None


def _run_json(cmd: list[str], env: dict[str, str] | None = None) -> dict[str, float]:
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-400:]}")
    data: dict[str, float] = json.loads(proc.stdout)
    return data


def reader(pure_python: bool) -> str:
    """Which ANDOR text reader the flexhrc side uses: the compiled common case (built by the
    install) or, with ``--pure-python`` or when it is not built, the pure-Python one."""
    if pure_python:
        return "pure Python (FLEXHRC_PURE_PYTHON=1)"
    try:
        import flexhrc.representation.formats._andor_fast  # noqa: F401
    except ImportError:
        return "pure Python (the compiled reader is not built)"
    return "compiled common case (_andor_fast)"


def parity(
    anchors: Path, cpp: Path, seeds: int, pure_python: bool = False
) -> tuple[list[dict[str, object]], int]:
    """Both sides on the same files, alternating per seed; medians. Returns rows, failures."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    env["FLEXHRC_PURE_PYTHON"] = "1" if pure_python else "0"
    files = sorted({rel for _, rel, _, _ in PARITY})
    ours: dict[str, list[dict[str, float]]] = {rel: [] for rel in files}
    theirs: dict[str, list[dict[str, float]]] = {rel: [] for rel in files}
    for seed in range(1, seeds + 1):
        for rel in files:
            path = str(anchors / rel)
            print(f"  seed {seed}: {rel}", file=sys.stderr, flush=True)
            theirs[rel].append(_run_json([str(cpp), path, "--seed", str(seed)]))
            ours[rel].append(
                _run_json(
                    [
                        sys.executable,
                        "-m",
                        "flexhrc",
                        "graph",
                        "play",
                        path,
                        "--policy",
                        "random",
                        "--seed",
                        str(seed),
                        "--json",
                    ],
                    env,
                )
            )
    rows: list[dict[str, object]] = []
    failures = 0
    for label, rel, metric, target in PARITY:
        a = statistics.median(r[metric] for r in ours[rel])
        b = statistics.median(r[metric] for r in theirs[rel])
        ratio_ = a / b
        ok = ratio_ <= target
        failures += not ok
        rows.append(
            {
                "graph": label,
                "metric": METRIC[metric],
                "flexhrc_s": a,
                "cpp_s": b,
                "ratio": ratio_,
                "target": target,
                "pass": ok,
            }
        )
    return rows, failures


def print_parity(rows: list[dict[str, object]], seeds: int, reader_: str = "") -> None:
    print(f"parity with the C++ ANDOR (g++ -O2), side by side, medians of {seeds} seeds")
    if reader_:
        print(f"flexhrc's ANDOR text reader: {reader_}")
    head = f"{'graph':<22}{'metric':<11}{'flexhrc':>10}{'C++':>10}{'ratio':>8}  target  verdict"
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['graph']!s:<22}{r['metric']!s:<11}{fmt(float(r['flexhrc_s'])):>10}"  # type: ignore[arg-type]
            f"{fmt(float(r['cpp_s'])):>10}{float(r['ratio']):>7.2f}x  "  # type: ignore[arg-type]
            f"<= {float(r['target']):.1f}x  {'PASS' if r['pass'] else 'FAIL'}"  # type: ignore[arg-type]
        )
    print()


# ----------------------------------------------------------------------------------------------
# Fig. 6, the result: path enumeration against the DP and the C++ (issue 21, item 7)
# ----------------------------------------------------------------------------------------------

#: The paper's three representations of the table task (§VII-B, Fig. 6): the file of n legs
#: and the largest n the authors published.
REPRESENTATIONS: dict[str, tuple[str, int]] = {
    "FOL": ("TRO-TableAssembly/{n}Leg/TableAssembly.txt", 10),
    "standard": ("TRO-PL_FOL-TableAssembly/{n}Leg/TableAssemblyPL.txt", 5),
    "hierarchical": ("TRO-TableAssembly/{n}Leg/TableAssembly_hierarchical.txt", 10),
}
#: Methods: flexhrc's path enumeration (``graph suggest --exact``), flexhrc's DP, the C++ ANDOR.
METHODS = ("enumeration", "DP", "C++")
#: Queries the enumeration's online time is the median of (each one re-enumerates every path).
ENUM_QUERIES = 3
#: The paper's Fig. 6 offline figures quoted in its text (i7-4790, ROS): (representation, legs).
PAPER_FIG6: dict[tuple[str, int], float] = {
    ("FOL", 1): 2.5e-4,
    ("FOL", 9): 1.98e3,
    ("hierarchical", 1): 2.8e-4,
    ("hierarchical", 9): 7.6e-4,
    ("standard", 5): 349.0,
}
# Line styles of the plot: the paper's colours per representation (standard dotted red, FOL
# dashed blue, hierarchical solid black); a marker and a line style per method.
_COLOUR = {"standard": "tab:red", "FOL": "tab:blue", "hierarchical": "black"}
_STYLE = {"enumeration": ("-", "o"), "C++": ("--", "s"), "DP": (":", "^")}


def enumerate_once(path: Path, seed: int, queries: int = ENUM_QUERIES) -> dict[str, object]:
    """flexhrc's path enumeration on ``path``, timed from inside (the ``--enumerate`` worker).

    Offline: load, build the online graph, then the suggestion cost of every feasible element by
    enumerating every cooperation path of every instance (:func:`exact_costs`, what ``graph
    suggest --exact`` prints) — the paper's offline phase, which generates the paths and their
    costs. Online: the authors' random client for ``queries`` queries, each answered by a DP
    update (statuses) and the enumerated costs."""
    import random

    from flexhrc.representation.formats import reader_for
    from flexhrc.representation.paths import exact_costs

    reader_for(path)  # the reader's code is loaded before the clock, as in ``graph play``
    t0 = time.perf_counter()
    online = OnlineGraph(load(path))
    exact_costs(online, sys.maxsize)
    offline = time.perf_counter() - t0
    rng = random.Random(seed)
    answer = online.update()
    times: list[float] = []
    while answer.outcome == "running" and len(times) < queries:
        e = rng.choice(sorted(answer.element_ids))
        name = online._names[e]
        t = time.perf_counter()
        if online._kind[e]:
            answer = online.update(solved_hyperarcs=(name,))
        else:
            answer = online.update(met_nodes=(name,))
        if answer.outcome == "running":
            exact_costs(online, sys.maxsize)
        times.append(time.perf_counter() - t)
    return {
        "offline_s": offline,
        "online_s_per_query_median": statistics.median(times) if times else 0.0,
        "queries": len(times),
    }


def _limit_memory(gib: float) -> None:
    """Cap the address space of a benchmark child (a path enumeration holds every path)."""
    import resource

    limit = int(gib * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def run_capped(
    cmd: list[str], time_limit: float, memory_gib: float, env: dict[str, str] | None = None
) -> dict[str, float] | str:
    """One fresh process, timed from inside (JSON on stdout), or why it has no figure:
    ``"time"`` (past ``time_limit``, killed) or ``"memory"`` (past ``memory_gib``)."""
    try:
        proc = subprocess.run(
            cmd,
            capture_output=True,
            text=True,
            env=env,
            timeout=time_limit,
            preexec_fn=lambda: _limit_memory(memory_gib),
        )
    except subprocess.TimeoutExpired:
        return "time"
    if proc.returncode == 3 or "MemoryError" in proc.stderr or "bad_alloc" in proc.stderr:
        return "memory"
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-400:]}")
    data: dict[str, float] = json.loads(proc.stdout)
    return data


@dataclass
class Point:
    """One representation, method and number of legs: medians of its runs, or why none."""

    representation: str
    method: str
    legs: int
    runs: int = 0
    offline_s: float | None = None
    per_query_s: float | None = None
    capped: str | None = None  # "time", "memory" or "skipped" (a smaller graph was capped)


def enumerate_experiment(
    anchors: Path,
    legs: int,
    seeds: int,
    time_limit: float,
    memory_gib: float,
    cpp: Path | None,
) -> list[Point]:
    """Every (legs, representation, method) point, methods alternating per graph."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    methods = [m for m in METHODS if m != "C++" or cpp is not None]
    points: list[Point] = []
    capped: dict[tuple[str, str], str] = {}
    for n in range(1, legs + 1):
        for rep, (pattern, _) in REPRESENTATIONS.items():
            path = anchors / pattern.format(n=n)
            if not path.is_file():
                continue
            for method in methods:
                pt = Point(rep, method, n)
                points.append(pt)
                if (rep, method) in capped:
                    pt.capped = "skipped"
                    continue
                if method == "enumeration":
                    base = [sys.executable, str(Path(__file__).resolve()), "--enumerate-one"]
                    base.append(str(path))
                elif method == "DP":
                    base = [sys.executable, "-m", "flexhrc", "graph", "play", str(path)]
                    base += ["--policy", "random", "--json"]
                else:
                    base = [str(cpp), str(path)]
                offline: list[float] = []
                per_query: list[float] = []
                spent = 0.0
                for seed in range(1, seeds + 1):
                    t = time.perf_counter()
                    got = run_capped([*base, "--seed", str(seed)], time_limit, memory_gib, env)
                    spent += time.perf_counter() - t
                    label = f"{rep} {n} leg{'s' if n > 1 else ''}, {method}, seed {seed}"
                    if isinstance(got, str):
                        pt.capped = got
                        capped[rep, method] = got
                        limit = f"{time_limit:g} s" if got == "time" else f"{memory_gib:g} GiB"
                        print(f"  {label}: past the {got} limit ({limit})", file=sys.stderr)
                        break
                    offline.append(float(got["offline_s"]))
                    per_query.append(float(got["online_s_per_query_median"]))
                    print(
                        f"  {label}: offline {fmt(offline[-1])}, per query {fmt(per_query[-1])}",
                        file=sys.stderr,
                        flush=True,
                    )
                    if spent > time_limit:  # an expensive point: fewer seeds
                        break
                if offline and pt.capped is None:
                    pt.runs = len(offline)
                    pt.offline_s = statistics.median(offline)
                    pt.per_query_s = statistics.median(per_query)
    return points


def _cell(pt: Point | None, metric: str, time_limit: float) -> str:
    if pt is None:
        return "–"
    if pt.capped == "time":
        return f"> {time_limit:g} s"
    if pt.capped == "memory":
        return "out of mem"
    if pt.capped == "skipped":
        return "(capped)"
    value: float | None = getattr(pt, metric)
    return fmt(value)


def growth(points: list[Point], rep: str, method: str, a: int = 4, b: int = 8) -> float | None:
    """Offline time at ``b`` legs over that at ``a`` legs (None: not measured)."""
    lo = next((p for p in points if (p.representation, p.method, p.legs) == (rep, method, a)), None)
    hi = next((p for p in points if (p.representation, p.method, p.legs) == (rep, method, b)), None)
    if lo is None or hi is None or lo.offline_s is None or hi.offline_s is None:
        return None
    return hi.offline_s / lo.offline_s


def print_enumeration(points: list[Point], legs: int, time_limit: float, seeds: int) -> int:
    """The two tables (offline, online per query) and the growth lines; returns failures of
    the acceptance of issue 21 (only when 4 and 8 legs were run)."""
    ns = list(range(1, legs + 1))
    lines = [(rep, m) for rep in REPRESENTATIONS for m in METHODS]
    index = {(p.representation, p.method, p.legs): p for p in points}
    for metric, title in (("offline_s", "offline"), ("per_query_s", "online, per query")):
        print(
            f"Fig. 6, {title}: time against legs (medians of up to {seeds} seeds, "
            f"each run capped at {time_limit:g} s)"
        )
        head = f"{'representation':<16}{'method':<13}" + "".join(f"{n:>11}" for n in ns)
        print(head)
        print("-" * len(head))
        for rep, m in lines:
            if not any(k[:2] == (rep, m) for k in index):
                continue
            cells = "".join(f"{_cell(index.get((rep, m, n)), metric, time_limit):>11}" for n in ns)
            print(f"{rep:<16}{m:<13}{cells}")
        print()
    failures = 0
    print(
        "offline growth from 4 to 8 legs (the paper: exponential single-layer, flat hierarchical):"
    )
    if legs < 8:
        print("  (needs 4 and 8 legs: --legs 8 or more)")
    for rep, m in lines:
        g = growth(points, rep, m)
        if g is None:
            continue
        verdict = ""
        if (rep, m) == ("FOL", "enumeration"):
            ok = g >= 10.0
            verdict = f"  {'PASS' if ok else 'FAIL'} (>= 10x)"
            failures += not ok
        elif (m == "enumeration" and rep == "hierarchical") or m == "DP":
            ok = g < 3.0
            verdict = f"  {'PASS' if ok else 'FAIL'} (< 3x)"
            failures += not ok
        shown = f"{g:,.0f}" if g >= 100 else f"{g:.2f}"
        print(f"  {rep:<16}{m:<13}{shown:>10}x{verdict}")
    return failures


def plot_enumeration(points: list[Point], legs: int, time_limit: float, out: Path) -> None:
    """The paper's Fig. 6 layout: offline above, online below, time against legs, log scale."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from flexhrc.files import atomic_output

    fig, axes = plt.subplots(2, 1, figsize=(8, 10), sharex=True)
    for ax, metric, title in (
        (axes[0], "offline_s", "offline phase"),
        (axes[1], "per_query_s", "online phase, per query"),
    ):
        for rep in REPRESENTATIONS:
            for m in METHODS:
                pts = [p for p in points if (p.representation, p.method) == (rep, m)]
                xy = [(p.legs, getattr(p, metric)) for p in pts if getattr(p, metric) is not None]
                if not pts:
                    continue
                ls, marker = _STYLE[m]
                if xy:
                    ax.plot(
                        *zip(*xy, strict=True),
                        linestyle=ls,
                        marker=marker,
                        color=_COLOUR[rep],
                        label=f"{rep}, {m}",
                    )
                cut = [p.legs for p in pts if p.capped in ("time", "memory")]
                if cut:  # where the line stops: past the time (or memory) limit
                    ax.scatter(cut, [time_limit], marker="x", s=60, color=_COLOUR[rep], zorder=3)
        if metric == "offline_s":
            pp = [(n, v, rep) for (rep, n), v in PAPER_FIG6.items() if n <= legs]
            for n, v, rep in pp:
                ax.scatter(n, v, marker="*", s=90, color=_COLOUR[rep], zorder=4, alpha=0.6)
            if pp:
                ax.scatter([], [], marker="*", s=90, color="grey", label="the paper's text")
            ax.scatter([], [], marker="x", s=60, color="grey", label="stopped at the time limit")
        ax.axhline(time_limit, color="grey", linewidth=0.8, linestyle="-.")
        ax.set_yscale("log")
        ax.set_ylabel("seconds (log scale)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].set_xlabel("legs")
    axes[1].set_xticks(range(1, legs + 1))
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.suptitle(
        "Fig. 6 on the authors' table graphs: path enumeration (flexhrc --exact, C++ ANDOR)\n"
        f"against flexhrc's dynamic programming (each run capped at {time_limit:g} s)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(out) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--anchors", type=Path, default=DEFAULT_ANCHORS)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="the plot (default out/andor_paper.png; with --enumerate out/andor_fig6.png)",
    )
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--seeds", type=int, default=5, help="seeds of the parity runs (default 5)")
    ap.add_argument("--cpp", type=Path, default=None, help="the C++ andor_bench binary")
    ap.add_argument("--no-parity", action="store_true", help="skip the side-by-side parity")
    ap.add_argument("--parity-only", action="store_true", help="only the parity table")
    ap.add_argument(
        "--pure-python",
        action="store_true",
        help="flexhrc without its compiled reader (FLEXHRC_PURE_PYTHON=1) in the parity runs",
    )
    fig6 = ap.add_argument_group("Fig. 6, the result (--enumerate)")
    fig6.add_argument(
        "--enumerate",
        action="store_true",
        help="time path enumeration beside the DP and the C++ against legs (no parity table)",
    )
    fig6.add_argument("--legs", type=int, default=9, help="1..N legs (default 9, the paper's)")
    fig6.add_argument(
        "--time-limit", type=float, default=60.0, help="seconds each run may take (default 60)"
    )
    fig6.add_argument(
        "--memory-limit", type=float, default=3.0, help="GiB each run may use (default 3)"
    )
    fig6.add_argument("--no-cpp", action="store_true", help="leave the C++ ANDOR out")
    # the worker of one enumeration run (a fresh process, so that the time limit can kill it)
    ap.add_argument("--enumerate-one", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--seed", type=int, default=1, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.seeds < 1:
        ap.error("--seeds must be at least 1")
    if args.enumerate_one is not None:
        try:
            print(json.dumps(enumerate_once(args.enumerate_one, args.seed)))
        except MemoryError:
            return 3
        return 0
    if args.enumerate:
        if args.legs < 1:
            ap.error("--legs must be at least 1")
        if not args.time_limit > 0 or not args.memory_limit > 0:
            ap.error("--time-limit and --memory-limit must be positive")
        if not args.anchors.is_dir():
            print(f"--enumerate: {args.anchors} is not present (give --anchors)", file=sys.stderr)
            return 2
        cpp = None if args.no_cpp else find_cpp(args.cpp, args.anchors.parent / "andor-cpp")
        if cpp is None and not args.no_cpp:
            print("--enumerate: no C++ reference binary; its lines are left out", file=sys.stderr)
        print(
            f"--enumerate: 1..{args.legs} legs, up to {args.seeds} seeds, "
            f"{args.time_limit:g} s / {args.memory_limit:g} GiB per run",
            file=sys.stderr,
            flush=True,
        )
        points = enumerate_experiment(
            args.anchors, args.legs, args.seeds, args.time_limit, args.memory_limit, cpp
        )
        failures = print_enumeration(points, args.legs, args.time_limit, args.seeds)
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps({"enumerate": [p.__dict__ for p in points]}, indent=2))
        out = args.out or ROOT / "out" / "andor_fig6.png"
        try:
            plot_enumeration(points, args.legs, args.time_limit, out)
            print(f"\nplot: {out}")
        except ImportError:
            print("\n(matplotlib not installed: no plot)", file=sys.stderr)
        return 1 if failures else 0
    parity_failures = 0
    parity_rows: list[dict[str, object]] = []
    if not args.no_parity:
        if not args.anchors.is_dir():
            print(f"parity: skipped, {args.anchors} is not present", file=sys.stderr)
        else:
            cpp = find_cpp(args.cpp, args.anchors.parent / "andor-cpp")
            if cpp is None:
                print(
                    "parity: skipped, no C++ reference binary (build it with "
                    "../shared/anchors/andor-cpp/build.sh, or give --cpp)",
                    file=sys.stderr,
                )
            else:
                print(f"parity: {cpp} against flexhrc, {args.seeds} seeds", file=sys.stderr)
                parity_rows, parity_failures = parity(
                    args.anchors, cpp, args.seeds, args.pure_python
                )
                print_parity(parity_rows, args.seeds, reader(args.pure_python))
    if args.parity_only:
        if args.json and parity_rows:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps({"parity": parity_rows}, indent=2))
        return 1 if parity_failures else 0
    files = corpus(args.anchors)
    if not files:
        print(f"no graph files under {args.anchors}", file=sys.stderr)
        return 2
    rows = []
    t0 = time.perf_counter()
    for i, (label, path) in enumerate(files, 1):
        print(f"[{i}/{len(files)}] {label} ...", file=sys.stderr, flush=True)
        rows.append(measure(label, path, args.runs))
    print(f"measured in {time.perf_counter() - t0:.1f} s", file=sys.stderr)

    head = (
        f"{'graph':<22}{'elements':>9}{'queries':>8}  {'offline':>9} {'C++':>9} {'ratio':>16}  "
        f"{'per query':>10} {'C++':>9} {'ratio':>16}  targets"
    )
    print(head)
    print("-" * len(head))
    failures = 0
    for r in rows:
        cpp_off, cpp_q = CPP.get(r.label, (None, None))
        t_off, t_q = TARGETS.get(r.label, (None, None))
        verdicts = " ".join(v for v in (check(r.offline_s, t_off), check(r.per_query_s, t_q)) if v)
        failures += verdicts.count("FAIL")
        print(
            f"{r.label:<22}{r.size:>9}{r.queries:>8}  {fmt(r.offline_s):>9} {fmt(cpp_off):>9} "
            f"{ratio(r.offline_s, cpp_off):>16}  {fmt(r.per_query_s):>10} {fmt(cpp_q):>9} "
            f"{ratio(r.per_query_s, cpp_q):>16}  {verdicts}"
        )
    print()
    print("paper (i7-4790, ROS)      offline      online total   | flexhrc offline  online total")
    for label, (off, onl) in PAPER.items():
        r = next((r for r in rows if r.label == label), None)
        if r:
            print(
                f"  {label:<22}  {fmt(off):>9}  {fmt(onl):>12}   |  {fmt(r.offline_s):>12}  "
                f"{fmt(r.online_total_s):>12}"
            )
    fol = [r for r in rows if r.label.startswith("FOL ")]
    hier = [r for r in rows if r.label.startswith("hierarchical ")]
    allr = rows
    print()
    print("growth of the per-query time with graph size (log-log slope; 1 = linear):")
    for name, group in (
        ("single-layer FOL 1-10 legs", fol),
        ("hierarchical 1-10 legs", hier),
        ("all files", allr),
    ):
        if len(group) >= 3:
            s = slope(group)
            verdict = "at most linear" if s <= 1.1 else "SUPERLINEAR"
            print(f"  {name:<28} slope {s:.2f}  ({verdict})")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(
            json.dumps({"parity": parity_rows, "corpus": [r.__dict__ for r in rows]}, indent=2)
        )
    try:
        out = args.out or ROOT / "out" / "andor_paper.png"
        plot(rows, out)
        print(f"\nplot: {out}")
    except ImportError:
        print("\n(matplotlib not installed: no plot)", file=sys.stderr)
    return 1 if failures or parity_failures else 0


if __name__ == "__main__":
    sys.exit(main())
