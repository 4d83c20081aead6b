"""Fair benchmark: controllers of the shared interface, paired, on the frozen test set.

    python scripts/benchmark.py --controllers policy,pid --episodes 20 --out runs/benchmark
    python scripts/benchmark.py --controllers policy,pid --backend ray --out runs/benchmark_ray
    python scripts/benchmark.py --controllers pid,policy --families turbulence,steps --quick --out /tmp/bench
    python scripts/benchmark.py --split validation --controllers policy,lqi_tuned --out runs/benchmark_validation
    python scripts/benchmark.py --split validation --controllers policy --compare runs/a/best_policy.pt --out runs/ab
    python scripts/benchmark.py --controllers lqi_tuned --compare runs/s1/best_policy.pt runs/s2/best_policy.pt \
        runs/s3/best_policy.pt --mean-of s1,s2,s3 --out runs/three_seeds   # each seed, and the recipe as their mean

Every controller flies the same realisations (seeds of ``training.evaluation.seeds.TEST_SEEDS``,
which only this command flies) of each flight family (``training.evaluation.benchmark``: turbulence
rejection on straight legs at 1, 10 and 20 km, roll and pitch steps, calm steady-state error, the
Table 9 aircraft, the sweeps' robustness axes at a stressed value, the route's first corner), each scored on a window that
measures one thing. For every metric and pair of controllers: the paired difference with its 95 %
interval and the verdict (better, worse, no difference at 95 %). ``--split validation`` flies the
same families on the validation seeds (``VALIDATION_SEEDS``), for choices made with these measures.

Writes to ``--out``: ``benchmark.md`` (a table per family), ``benchmark.json`` (the rows, the
summary and the command), one PNG per family and ``command.txt``. ``--backend local`` and
``--backend ray`` give identical numbers. Every argument is checked before the first flight; an
``--out`` holding an earlier benchmark's results is refused unless ``--overwrite``, and one of
another command, or holding files no earlier benchmark recorded, always
(``training.output_folders``). The results are written to a temporary folder and moved into place
at the end: an error or a Ctrl-C leaves the earlier results as they were.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

# None of these loads torch, ray or onnxruntime: those load when flying, after the arguments are parsed.
from aircraft import load_aircraft
from jsbsim_env.control.factory import CONTROLLER_NAMES, check_flyable
from jsbsim_env.control.gain_files import GainsMissing, GainTableError
from jsbsim_env.task.metrics import json_ready
from training.evaluation import selection
from training.evaluation.benchmark import (
    FAMILIES,
    BenchmarkPlan,
    check_seed_labels,
    flown_labels,
    jobs_for,
    mean_of_seeds,
    plan_dict,
    plot_family,
    render_markdown,
    run_benchmark_job,
    summarise,
)
from training.evaluation.seeds import SPLITS, TEST_SEEDS
from training.evaluation.sweep import run_local, run_ray
from training.output_folders import OutputFolder, writing
from training.runtime import (
    OutputFolderError,
    ScriptParser,
    add_aircraft_options,
    available_cores,
    name_list,
    number_type,
    run_command,
    workers_int,
)
from training.workers import pool_size

RESULTS = ("benchmark.md", "benchmark.json", "command.txt", *(f"{f}.png" for f in FAMILIES))


def build_parser() -> argparse.ArgumentParser:
    p = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    p.add_argument("--controllers", default=",".join(CONTROLLER_NAMES),
                   help=f"comma-separated, any of: {', '.join(CONTROLLER_NAMES)}")
    add_aircraft_options(p, "the families fly at the same fractions of its envelope")
    p.add_argument("--policy", default=None, help="policy file (.pt); the shipped policy when omitted")
    p.add_argument("--compare", nargs="+", type=Path, default=(), metavar="POLICY",
                   help="more policy files, each flown as a controller of its own (named by its run folder, or its "
                        "file name), paired with the others: for choosing between trained policies on --split "
                        "validation")
    p.add_argument("--mean-of", action="append", default=[], metavar="LABELS",
                   help="comma-separated labels of --compare's policies (the seeds of one recipe), scored also as "
                        "one candidate, mean(LABELS): each metric their mean on each realisation; repeatable")
    p.add_argument("--network-alone", action="store_true",
                   help="also fly each policy whose file records classical stages (goal trim, surface trim) "
                        "without them: what the network does by itself")
    p.add_argument("--episodes", type=number_type(int, 1, len(TEST_SEEDS)), default=20,
                   help=f"realisations per condition of each family (1 to {len(TEST_SEEDS)}, the test set's size)")
    p.add_argument("--split", choices=tuple(SPLITS), default="test",
                   help="test: the frozen test set, for results; validation: other seeds, for choices")
    p.add_argument("--families", default=",".join(FAMILIES), help=f"comma-separated, any of: {', '.join(FAMILIES)}")
    p.add_argument("--method", choices=("t", "bootstrap"), default="t", help="the paired difference's 95 %% interval")
    p.add_argument("--out", type=Path, default=Path("runs/benchmark"), help="folder for the tables, JSON and plots")
    p.add_argument("--overwrite", action="store_true", help="replace the results of an earlier benchmark in --out")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local: a process pool; ray: Ray tasks (pip install '.[ray]'); the same numbers")
    p.add_argument("--workers", type=workers_int, default=available_cores(),
                   help="processes of the local backend (default: this machine's cores)")
    p.add_argument("--address", default=None, help="ray backend: a cluster's address ('auto': this machine's); "
                                                   "a local Ray instance when omitted")
    p.add_argument("--quick", action="store_true", help="short windows, for checks (not a benchmark)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout (no progress bar)")
    return p


def compare_labels(paths, controllers: list[str]) -> dict[str, str]:
    """``--compare``'s files by label: a run's ``best_policy.pt`` by its run folder's name, its
    ``picked_policy.pt`` (``scripts/heldout.py --checkpoints``) by that name and ``_picked``, another
    file by its name without suffix; a label that repeats, or names a controller, is refused."""
    labels: dict[str, str] = {}
    for path in paths:
        label = path.stem
        if path.name in ("best_policy.pt", "picked_policy.pt") and path.parent.name:
            label = path.parent.name + ("_picked" if path.name == "picked_policy.pt" else "")
        if label in labels or label in controllers:
            raise ValueError(f"two controllers would be named {label!r} ({path}); give files whose run folders or "
                             "names differ")
        labels[label] = str(path)
    return labels


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    command = shlex.join(["python", "scripts/benchmark.py", *(sys.argv[1:] if argv is None else argv)])
    out = OutputFolder(args.out, "benchmark", RESULTS, args.overwrite, command)
    try:
        controllers = name_list(args.controllers, CONTROLLER_NAMES, "--controllers")
        families = name_list(args.families, tuple(FAMILIES), "--families")
        flown_aircraft = load_aircraft(args.aircraft)
        out.claim()
    except OutputFolderError as err:
        print(f"benchmark: --out: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        print(f"benchmark: {err}", file=sys.stderr)
        return 2
    try:
        compared = compare_labels(args.compare, controllers)
    except ValueError as err:
        print(f"benchmark: --compare: {err}", file=sys.stderr)
        return 2
    means = [[label.strip() for label in group.split(",")] for group in args.mean_of]
    policies = [*(["policy"] if "policy" in controllers else []), *compared]
    for labels in means:
        try:
            check_seed_labels(labels, policies)
        except ValueError as err:
            print(f"benchmark: --mean-of: {err}", file=sys.stderr)
            return 2
    from jsbsim_env.control.policy import PolicyFileError, shipped_policy_path

    flown = ({"policy": args.policy or shipped_policy_path()} if "policy" in controllers else {}) | compared
    try:  # every gain table and policy file read and checked once here, before any flight
        metas = check_flyable(controllers, flown_aircraft, flown, args.transfer)
    except (PolicyFileError, GainsMissing, GainTableError) as err:
        print(f"benchmark: {err}", file=sys.stderr)
        return 2
    # The policies --network-alone flies without their classical stages.
    alone = [label for label, meta in metas.items() if meta["stack"].network_alone() != meta["stack"]]
    if args.network_alone and not alone:
        print("benchmark: --network-alone needs a policy with classical stages (goal trim or surface trim) to take "
              "away: the policy controller or --compare", file=sys.stderr)
        return 2
    from tqdm import tqdm

    jobs = jobs_for(families, controllers, args.episodes, args.quick, args.split, compared,
                    alone if args.network_alone else (), args.policy, args.aircraft, args.transfer)
    controllers = flown_labels(jobs)
    bar = tqdm(total=len(jobs), desc=f"benchmark ({args.backend})", unit="flight", file=sys.stderr,
               disable=args.no_progress or args.json)
    started = time.perf_counter()
    workers = pool_size(args.workers, len(jobs))
    try:
        info = {"cpus": float(workers)}
        if args.backend == "ray":
            rows = run_ray(jobs, args.policy, args.address, bar.update, info, run=run_benchmark_job)
        else:
            rows = run_local(jobs, args.policy, workers, bar.update, run=run_benchmark_job)
    except RuntimeError as err:
        print(f"benchmark: {err}", file=sys.stderr)
        return 2
    finally:
        bar.close()
    wall_s = time.perf_counter() - started
    for labels in means:
        name, mean_rows = mean_of_seeds(rows, labels)
        rows, controllers = rows + mean_rows, [*controllers, name]
    try:
        with writing(out) as staging:
            record = write_results(staging, args, rows, controllers, families, flown_aircraft, command, info, wall_s)
    except OutputFolderError as err:  # the folder changed during the flights
        print(f"benchmark: --out: {err}", file=sys.stderr)
        return 2
    print(json.dumps(json_ready(record), indent=1) if args.json
          else f"{len(rows)} flights in {wall_s:.0f} s; written to {args.out}/")
    return 0


def write_results(folder: Path, args, rows, controllers, families, flown_aircraft, command, info, wall_s) -> dict:
    """The benchmark's files in ``folder``; returns the record (``benchmark.json`` without its rows)."""
    (folder / "command.txt").write_text(command + "\n")
    plan = BenchmarkPlan.quick() if args.quick else BenchmarkPlan()
    summary = summarise(rows, controllers, args.method)
    record = {"command": command, "backend": args.backend, "cores": info["cpus"], "wall_s": wall_s,
              "flights": len(rows), "controllers": controllers, "families": families, "episodes": args.episodes,
              "split": args.split, "aircraft": flown_aircraft.name, "aircraft_model": flown_aircraft.fingerprint,
              "seeds": [SPLITS[args.split].start, SPLITS[args.split].start + args.episodes - 1],
              "method": args.method,
              "quick": args.quick, "plan": plan_dict(args.quick), "summary": summary,
              "selection": [{"controller": c, **s} for c, s in selection.rank(summary, *selection.sides(controllers))]}
    (folder / "benchmark.json").write_text(json.dumps(json_ready({**record, "rows": rows}), indent=1))
    (folder / "benchmark.md").write_text(render_markdown(summary, controllers, plan, args.episodes, command,
                                                         args.method, args.split, args.aircraft))
    for family in families:
        plot_family(rows, family, controllers, folder / f"{family}.png", args.aircraft)
    return record


if __name__ == "__main__":
    run_command(main, __file__)
