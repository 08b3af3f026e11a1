#!/usr/bin/env python3
"""How the tracker's defaults are chosen on the robustness grid, honestly.

  tune_grid.py sample N CONFIGS.jsonl [--seed S] [--space online|offline]
      N random configs from the search space (the first line is the current defaults).
  shapetrack grid eval --mode online --input boxes --configs CONFIGS.jsonl --results R.jsonl
      evaluates them all in one process (datasets and detections loaded once).
  tune_grid.py select R.jsonl PEERS.json [--mode online|offline] [--top K] [--require CELL>=HOTA]
      scores every config against the best peer of each cell, picks the best on all cells,
      and reports leave-one-dataset-out (LODO) and leave-one-detector-model-out figures: for
      each held-out dataset (model), the config chosen on every other cell, scored on the
      held-out cells only. PEERS.json is `shapetrack grid score --json` of a grid run (or
      grid.json's "ours" part), holding the peers' per-cell results.

  tune_grid.py local START.json PEERS.json RESULTS.jsonl [--rounds N] [--require CELL>=HOTA]
                     [--datasets D,..] [--bin PATH]
      a local search from START (an online config): each round evaluates every one-field
      change of the current best (the space's other values), in one `grid eval` process, and
      moves to the best change that raises the objective while meeting the requirements;
      every evaluated config is appended to RESULTS (the pool `select` chooses from).

Objective (per set of cells): mean over cells of (ours − best peer) HOTA, plus the mean of its
negative part again, so a cell lost counts double and a config that wins everywhere by a
little beats one that wins big on some cells and loses on others. Only the standard library
is needed.
"""
import collections, json, os, random, sys

PEERS = ["rf_sort", "rf_bytetrack", "norfair", "ocsort", "motpy"]

# The online box-mode search space: each key is a Config field (dotted for nested ones).
ONLINE = {
    "score_adaptation": [None, {"high_quantile": 0.0, "birth_quantile": 0.1},
                         {"high_quantile": 0.0, "birth_quantile": 0.2},
                         {"high_quantile": 0.0, "birth_quantile": 0.35},
                         {"high_quantile": 0.02, "birth_quantile": 0.2},
                         {"high_quantile": 0.0, "birth_quantile": 0.5}],
    "birth_evidence": [None, 0.25, 0.34, 0.5, 0.75],
    "min_hits": [3, 4, 5, 6, 8],
    "min_hits_floor": [1, 2, 3, 4294967295],
    "max_tentative_misses": [0, 1],
    "max_lost": [30, 45, 60, 90],
    "coast_frames": [0, 2, 3, 5, 8],
    "coasting": [None, {}, {"min_probability": 0.7}],
    "max_cost": [0.7, 0.75, 0.8],
    "max_cost_low": [0.5, 0.6, 0.7],
    "max_cost_tentative": [0.6, 0.75, 0.9],
    "terms.iou.scale": [1.0, 1.15, 1.3],
    "motion_per_second": [False, True],
    "motion.std_measurement": [0.03, 0.06, 0.1],
    "motion.std_velocity": [0.00625, 0.0125, 0.025],
    "motion.std_position": [0.01, 0.02, 0.04],
    "region_margin": [0.5, 1.0],
    "spawn_max_iou": [1.0, 0.7, 0.5],
    "reupdate_after_gap": [False, True],
    "lost_second": [False, True],
}

# The offline search space (over the chosen online defaults): OfflineConfig fields.
OFFLINE = {
    "relink.max_gap_seconds": [2.0, 5.0, 8.0],
    "relink.gate_base": [0.3, 0.5, 0.8],
    "relink.gate_per_second": [0.25, 0.5, 1.0],
    "relink.max_size_ratio": [1.2, 1.5, 2.0],
    "relink.history_seconds": [0.8, 1.5, 3.0],
    "relink.bidirectional": [True, False],
    "relink.stay_in_view": [True, False],
    "fill.max_gap": [10, 20, 40, 80],
    "fill.trajectory": ["linear", "kalman"],
}


def nest(flat):
    out = {}
    for k, v in flat.items():
        d = out
        parts = k.split(".")
        for p in parts[:-1]:
            d = d.setdefault(p, {})
        d[parts[-1]] = v
    return out


def sample(n, path, seed, space):
    rng = random.Random(seed)
    key = "online" if space is ONLINE else "offline"
    with open(path, "w") as f:
        f.write(json.dumps({"label": "defaults"}) + "\n")
        for i in range(n):
            flat = {k: rng.choice(v) for k, v in space.items()}
            f.write(json.dumps({"label": f"r{seed}-{i}", key: nest(flat)}) + "\n")


def objective(margins):
    if not margins:
        return float("-inf")
    m = list(margins)
    return sum(m) / len(m) + sum(min(x, 0.0) for x in m) / len(m)


def best_peers(peers):
    """The best peer's HOTA per cell (cells with at least one peer)."""
    return {c: max(v[p]["HOTA"] for p in PEERS if p in v) for c, v in peers.items()
            if any(p in v for p in PEERS)}


def requirements(args):
    """`--require CELL>=HOTA` options, as (cell, floor) pairs."""
    out = []
    for i, x in enumerate(args):
        if i and args[i - 1] == "--require":
            cell, floor = x.split(">=")
            out.append((cell, float(floor)))
    return out


def group(cell, by):
    ds, model = cell.split("/")
    if by == "dataset":
        return "synth" if ds.startswith("synth-") else ds
    return model


def select(results_path, peers_path, mode, top, require=()):
    peers = json.load(open(peers_path))
    best = best_peers(peers)
    sort = {c: v["rf_sort"]["HOTA"] for c, v in peers.items() if "rf_sort" in v}
    runs = [json.loads(l) for l in open(results_path) if l.strip()]
    rows = []
    for r in runs:
        ours = {c: t[mode]["HOTA"] for c, t in r["cells"].items() if mode in t and c in best}
        rows.append((r, ours))
    # Hard requirements (e.g. MOT15's real detections must keep online HOTA ≥ 39).
    for cell, floor in require:
        rows = [(r, o) for r, o in rows if r["cells"].get(cell, {}).get(mode, {}).get("HOTA", -1) >= floor]
    cells = sorted(set.intersection(*[set(o) for _, o in rows])) if rows else []

    def obj(ours, subset):
        return objective([ours[c] - best[c] for c in subset])

    def report(ours, subset):
        m = [ours[c] - best[c] for c in subset]
        wins = sum(x >= 0 for x in m)
        ge_sort = sum(ours[c] >= sort.get(c, -1) for c in subset)
        mean = sum(ours[c] for c in subset) / len(subset)
        return f"mean HOTA {mean:6.2f}, vs best peer {sum(m) / len(m):+6.2f} (worst {min(m):+6.2f}), " \
               f"≥ best peer {wins}/{len(subset)}, ≥ SORT {ge_sort}/{len(subset)}"

    ranked = sorted(rows, key=lambda ro: obj(ro[1], cells), reverse=True)
    print(f"{len(rows)} configs, {len(cells)} cells ({mode})\n")
    print("best on all cells:")
    for r, ours in ranked[:top]:
        print(f"  {r['label']:16} objective {obj(ours, cells):+7.3f}  {report(ours, cells)}")
    chosen, chosen_ours = ranked[0]
    print("\nchosen:", json.dumps(chosen.get(mode if mode == 'online' else 'offline') or chosen.get("online") or {}))
    for by in ("dataset", "model"):
        groups = sorted(set(group(c, by) for c in cells))
        print(f"\nleave one {by} out (config chosen on the other cells, scored on the held-out ones):")
        held = collections.OrderedDict()
        for g in groups:
            train = [c for c in cells if group(c, by) != g]
            test = [c for c in cells if group(c, by) == g]
            r, ours = max(rows, key=lambda ro: obj(ro[1], train))
            held[g] = (r["label"], ours, test)
            print(f"  {g:12} chose {r['label']:16} → {report(ours, test)}")
        allm = [ours[c] - best[c] for _, ours, test in held.values() for c in test]
        wins = sum(x >= 0 for x in allm)
        print(f"  all held-out cells: mean vs best peer {sum(allm) / len(allm):+.2f}, ≥ best peer {wins}/{len(allm)}")
    print("\nper cell (chosen config):")
    for c in cells:
        print(f"  {c:30} ours {chosen_ours[c]:6.2f}  best peer {best[c]:6.2f}  SORT {sort.get(c, float('nan')):6.2f}  {chosen_ours[c] - best[c]:+6.2f}")


def flatten(d, prefix=""):
    out = {}
    for k, v in (d or {}).items():
        key = prefix + k
        if isinstance(v, dict) and key in ONLINE:
            out[key] = v
        elif isinstance(v, dict) and any(s.startswith(key + ".") for s in ONLINE):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def local(start_path, peers_path, results_path, rounds, require, datasets, binary):
    import subprocess, tempfile
    peers = json.load(open(peers_path))
    best = best_peers(peers)

    def score(rec):
        ours = {c: t["online"]["HOTA"] for c, t in rec["cells"].items() if c in best}
        if any(rec["cells"].get(c, {}).get("online", {}).get("HOTA", -1) < f for c, f in require):
            return float("-inf")
        return objective([ours[c] - best[c] for c in ours])

    def evaluate(configs):
        with tempfile.NamedTemporaryFile("w", suffix=".jsonl", delete=False) as f:
            for label, cfg in configs:
                f.write(json.dumps({"label": label, "online": nest(cfg)}) + "\n")
            path = f.name
        before = sum(1 for _ in open(results_path)) if os.path.exists(results_path) else 0
        try:
            subprocess.run([binary, "grid", "eval", "--datasets", datasets, "--mode", "online",
                            "--input", "boxes", "--configs", path, "--results", results_path],
                           check=True, capture_output=True)
        finally:
            os.unlink(path)
        return [json.loads(l) for l in list(open(results_path))[before:]]

    center = flatten(json.load(open(start_path)))
    rec = evaluate([("local-start", center)])[0]
    cur = score(rec)
    print(f"start: objective {cur:+.3f}", flush=True)
    for rnd in range(rounds):
        cands = []
        for k, values in ONLINE.items():
            for v in values:
                if center.get(k, "__unset__") == v:
                    continue
                c = dict(center)
                c[k] = v
                cands.append((f"local-{rnd}-{k}={json.dumps(v)}", c))
        recs = evaluate(cands)
        scored = sorted(((score(r), r, c) for r, (_, c) in zip(recs, cands)), key=lambda x: -x[0])
        s, r, c = scored[0]
        print(f"round {rnd}: best move {r['label']} → {s:+.3f} (was {cur:+.3f})", flush=True)
        if s <= cur + 1e-3:
            break
        cur, center = s, c
    print("local optimum:", json.dumps(nest(center)))


def main():
    a = sys.argv[1:]
    if not a:
        sys.exit(__doc__)
    if a[0] == "sample":
        seed = int(a[a.index("--seed") + 1]) if "--seed" in a else 1
        space = OFFLINE if "--space" in a and a[a.index("--space") + 1] == "offline" else ONLINE
        sample(int(a[1]), a[2], seed, space)
    elif a[0] == "select":
        mode = a[a.index("--mode") + 1] if "--mode" in a else "online"
        top = int(a[a.index("--top") + 1]) if "--top" in a else 5
        select(a[1], a[2], mode, top, requirements(a))
    elif a[0] == "local":
        rounds = int(a[a.index("--rounds") + 1]) if "--rounds" in a else 6
        datasets = a[a.index("--datasets") + 1] if "--datasets" in a else "mot15,sportsmot,bdd,bdd-masks,synth"
        binary = a[a.index("--bin") + 1] if "--bin" in a else "target/release/shapetrack"
        local(a[1], a[2], a[3], rounds, requirements(a), datasets, binary)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
