"""Summaries, acceptance targets and ``table.md`` of the quality benchmark (``quality.py``).

Everything here reads the benchmark's results dict (as in ``results.json``) only, so tables can be
made again from a saved run.
"""

import math
from dataclasses import dataclass

import numpy as np

SPLITS = ("tuning", "held-out")
BUMPS_ONLY = ("stripes", "high", "isolated", "sparse")
# metric -> (title, format); the summary gives median and maximum of each
SUMMARY_METRICS = {
    "noise_left": ("noise left", "{:.1%}"),
    "bumps_left": ("bumps left", "{:.1%}"),
    "dents_left": ("dents left", "{:.1%}"),
    "clean_lost": ("clean lost", "{:.2%}"),
    "new_material": ("new material", "{:.2%}"),
    "bumps_left_thin": ("bumps left, parts ≤ 3 thick", "{:.1%}"),
    "bumps_left_thick": ("bumps left, parts ≥ 13 thick", "{:.1%}"),
    "bumps_left_over_2h": ("bumps left, parts over 2 h thick", "{:.1%}"),
    "concavity_filled": ("concavities filled", "{:.2%}"),
    "thin_kept": ("thin parts kept", "{:.1%}"),
    "error_ratio": ("voxel error / input's", "{:.2f}"),
    "chamfer": ("Chamfer", "{:.3f}"),
    "normal_error_deg": ("normal (°)", "{:.1f}"),
    "sharp_edge_mean": ("sharp edge", "{:.2f}"),
}
CELL_LEGEND = ("noise left · Chamfer (vox) · normal error (°) · sharp-edge error (vox), in voxels of the noise "
               "grid; **g≠** the mesh's genus differs from the clean shape's, **vg≠** the genus of its "
               "voxelization on the noise grid does")


def methods(results):
    """Column order: the noisy reference, skelfilter's variants, the per-ball oracle (``--oracle``),
    the rivals."""
    s = results["settings"]
    return ["noisy"] + list(s["variants"]) + (["oracle"] if s.get("oracle") else []) + list(s["rivals"])


def _entry(case, method):
    """A method's scores on a case, or None when it is missing or failed."""
    entry = case["methods"].get(method)
    return entry if entry is not None and entry.get("error") is None else None


def _number(value):
    return value is not None and not (isinstance(value, float) and math.isnan(value))


def genus_equal(results, case, entry, key="genus"):
    """Whether a result has the genus (``genus`` or ``voxel_genus``) the case's clean shape measures."""
    return entry[key] == results["shapes"][case["shape"]][key]


def best_rivals(results, n):
    """The ``n`` rivals with the lowest median Chamfer over the cases they succeeded on."""
    medians = {}
    for rival in results["settings"]["rivals"]:
        values = [e["chamfer"] for c in results["cases"] if (e := _entry(c, rival)) is not None]
        if values:
            medians[rival] = float(np.median(values))
    return sorted(medians, key=medians.get)[:n]


# ----------------------------------------------------------------------------------------------- summary


def summary(results):
    """Per split, method and noise kind (and ``all``): median and maximum of `SUMMARY_METRICS`, the
    median time, and how many results have the clean genus out of how many succeeded.

    Returns
    -------
    dict
        ``{split: {method: {kind: {"n", "failed", "genus_equal", "voxel_genus_equal", "seconds_median",
        metric: {"median",
        "max"}}}}}``; a metric without any value is left out.
    """
    out = {}
    for split in SPLITS:
        cases = [c for c in results["cases"] if c["split"] == split]
        if not cases:
            continue
        kinds = list(dict.fromkeys(c["kind"] for c in cases)) + ["all"]
        out[split] = {}
        for method in methods(results):
            out[split][method] = {}
            for kind in kinds:
                own = [c for c in cases if kind in ("all", c["kind"]) and method in c["methods"]]
                good = [(c, e) for c in own if (e := _entry(c, method)) is not None]
                if not own:
                    continue
                row = {"n": len(good), "failed": len(own) - len(good),
                       "genus_equal": sum(genus_equal(results, c, e) for c, e in good),
                       "voxel_genus_equal": sum(genus_equal(results, c, e, "voxel_genus") for c, e in good),
                       "seconds_median": float(np.median([e["seconds"] for _, e in good])) if good else None}
                for key in SUMMARY_METRICS:
                    values = [e[key] for _, e in good if _number(e.get(key))]
                    if values:
                        row[key] = {"median": float(np.median(values)), "max": float(np.max(values))}
                out[split][method][kind] = row
    return out


# ----------------------------------------------------------------------------------------------- acceptance


@dataclass(frozen=True)
class Target:
    """An acceptance target: values (per case or shape) that must stay within ``limit``."""

    text: str
    values: object  # (results, cases of the split, checked variant) -> [(what, value or None)]
    limit: float
    fmt: str = "{:.3f}"
    median: bool = False  # the median must be within the limit, not every value
    strict: bool = False  # value < limit rather than <=


def _per_case(value, kinds=None, cad=False):
    """A Target's ``values``: ``value(entry, case, results)`` of the checked variant on the cases of
    ``kinds`` (all kinds when None; only CAD shapes with ``cad``) that it ran on. A failed run counts
    as infinity; ``value`` returns None where the target does not apply."""
    def values(results, cases, check):
        out = []
        for case in cases:
            if (check not in case["methods"] or (kinds and case["kind"] not in kinds)
                    or (cad and not results["shapes"][case["shape"]]["cad"])):
                continue
            entry = _entry(case, check)
            out.append((case["name"], math.inf if entry is None else value(entry, case, results)))
        return out
    return values


def _metric(key):
    return lambda entry, case, results: entry[key]


def _chamfer_to_noisy(entry, case, results):
    noisy = _entry(case, "noisy")
    return None if noisy is None else entry["chamfer"] / noisy["chamfer"]


def _chamfer_to_best_rival(entry, case, results):
    rivals = [e["chamfer"] for r in results["settings"]["rivals"] if (e := _entry(case, r)) is not None]
    return entry["chamfer"] / min(rivals) if rivals else None


def _normal_to_smoothers(entry, case, results):
    rivals = [e["normal_error_deg"] for r in ("laplacian", "two-step") if (e := _entry(case, r)) is not None]
    return entry["normal_error_deg"] / min(rivals) if rivals else None


def _chamfer_to_laplacian(entry, case, results):
    laplacian = _entry(case, "laplacian")
    return None if laplacian is None else entry["chamfer"] / laplacian["chamfer"]


def _per_kind_median(key, kinds):
    """A Target's ``values``: the checked variant's median ``key`` per noise kind of ``kinds``."""
    def values(results, cases, check):
        out = []
        for kind in kinds:
            pairs = _per_case(_metric(key), (kind,))(results, cases, check)
            numbers = [v for _, v in pairs if _number(v)]
            if numbers:
                out.append((kind, float(np.median(numbers))))
        return out
    return values


def _genus_share_differing(results, cases, check):
    """The share of the cases whose output's genus differs from the clean shape's (failures count)."""
    pairs = _per_case(_genus_change("genus"))(results, cases, check)
    return [("cases", float(np.mean([v != 0 for _, v in pairs])))] if pairs else []


def _genus_change(key):
    return lambda entry, case, results: abs(entry[key] - results["shapes"][case["shape"]][key])


def _clean_pass(key):
    """A Target's ``values``: the clean pass's ``key`` per shape of the split."""
    def values(results, cases, check):
        passes = results.get("clean_pass", {}).get(check, {})
        out = []
        for shape in dict.fromkeys(c["shape"] for c in cases):
            if shape in passes:
                entry = passes[shape]
                out.append((shape, math.inf if entry.get("error") else entry.get(key)))
        return out
    return values


def _worst_pass_distance(results, cases, check):
    """The larger of the clean pass's two 99 % vertex distances (fractions of the diagonal) per shape."""
    both = [_clean_pass(key)(results, cases, check) for key in ("source_to_result", "result_to_source")]
    return [(shape, max(a, b)) for (shape, a), (_, b) in zip(*both)]


def _components_change(entry, case, results):
    return abs(entry["components"] - results["shapes"][case["shape"]]["components"])


def companions(results, check):
    """Variants equal to ``check`` but for the denoise resolution."""
    variants = results["settings"]["variants"]
    if check not in variants:
        return []
    base = {k: v for k, v in variants[check].items() if k != "resolution"}
    return [label for label, params in variants.items()
            if params["resolution"] != variants[check]["resolution"]
            and {k: v for k, v in params.items() if k != "resolution"} == base]


def _resolution_agreement(results, cases, check):
    """|noise left at another resolution - noise left of ``check``| per case and companion variant."""
    out = []
    for other in companions(results, check):
        for case in cases:
            a, b = _entry(case, check), _entry(case, other)
            if other in case["methods"] and check in case["methods"]:
                out.append((f"{case['name']} ({other})",
                            math.inf if a is None or b is None else abs(a["noise_left"] - b["noise_left"])))
    return out


TARGETS = (
    Target("bumps-only cases (stripes, high, isolated, sparse): noise left ≤ 15 % on each",
           _per_case(_metric("noise_left"), BUMPS_ONLY), 0.15, "{:.1%}"),
    Target("bumps-only cases: median noise left ≤ 10 %",
           _per_case(_metric("noise_left"), BUMPS_ONLY), 0.10, "{:.1%}", median=True),
    Target("bumps-only cases: clean lost ≤ 0.5 % on each",
           _per_case(_metric("clean_lost"), BUMPS_ONLY), 0.005, "{:.2%}"),
    Target("bumps-only cases: new material ≤ 0.5 % on each",
           _per_case(_metric("new_material"), BUMPS_ONLY), 0.005, "{:.2%}"),
    Target("bumps-dents: bumps left ≤ 25 % on each",
           _per_case(_metric("bumps_left"), ("bumps-dents",)), 0.25, "{:.1%}"),
    Target("bumps-dents: dents left ≤ 25 % on each",
           _per_case(_metric("dents_left"), ("bumps-dents",)), 0.25, "{:.1%}"),
    Target("bumps-dents: Chamfer below the noisy input's (ratio < 1)",
           _per_case(_chamfer_to_noisy, ("bumps-dents",)), 1.0, "{:.2f}", strict=True),
    Target("stripes: Chamfer ≤ 0.7 × the best rival's (ratio)",
           _per_case(_chamfer_to_best_rival, ("stripes",)), 0.7, "{:.2f}"),
    Target("stripes: normal error below Laplacian's and Two-step's (ratio to the lower < 1)",
           _per_case(_normal_to_smoothers, ("stripes",)), 1.0, "{:.2f}", strict=True),
    Target("CAD shapes: sharp-edge error ≤ 1.0 voxel on each",
           _per_case(_metric("sharp_edge_mean"), cad=True), 1.0, "{:.2f}"),
    Target("genus(out) = genus(clean) on every case (|difference|)",
           _per_case(_genus_change("genus")), 0, "{:.0f}"),
    Target("the same on the voxelizations on the noise grid (|difference|; no sub-voxel tunnels)",
           _per_case(_genus_change("voxel_genus")), 0, "{:.0f}"),
    Target("clean shapes through the variant: ≤ 0.5 % of voxels changed (--clean-pass)",
           _clean_pass("changed"), 0.005, "{:.2%}"),
    Target("clean shapes: 99 % of the vertices each way within 0.5 % of the diagonal (--clean-pass)",
           _worst_pass_distance, 0.005, "{:.3%}"),
    Target("clean shapes: volume within 0.5 % (--clean-pass)",
           _clean_pass("volume_change"), 0.005, "{:.3%}"),
    Target("every noisy case: thin parts kept ≥ 90 % (1 − kept ≤ 0.1)",
           _per_case(lambda e, c, r: 1.0 - e["thin_kept"]), 0.1, "{:.1%}"),
    Target("every noisy case: components equal to the clean shape's (|difference|)",
           _per_case(_components_change), 0, "{:.0f}"),
    Target("every noisy case: Chamfer below the best rival's (ratio < 1)",
           _per_case(_chamfer_to_best_rival), 1.0, "{:.2f}", strict=True),
    Target("bumps-dents: clean lost ≤ 1 % on each",
           _per_case(_metric("clean_lost"), ("bumps-dents",)), 0.01, "{:.2%}"),
    Target("every noisy case: Chamfer ≤ the noisy input's (ratio ≤ 1: never worse than doing nothing)",
           _per_case(_chamfer_to_noisy), 1.0, "{:.2f}"),
    Target("bumps-dents: Chamfer below MeshLab Laplacian's on the median (ratio < 1)",
           _per_case(_chamfer_to_laplacian, ("bumps-dents",)), 1.0, "{:.2f}", median=True, strict=True),
    Target("bumps-dents: median dents left ≤ 35 %",
           _per_case(_metric("dents_left"), ("bumps-dents",)), 0.35, "{:.1%}", median=True),
    Target("bumps-dents: median bumps left ≤ 30 %",
           _per_case(_metric("bumps_left"), ("bumps-dents",)), 0.30, "{:.1%}", median=True),
    Target("every noisy case: the clean shape's concavities (deeper than the noise) filled ≤ 1 %",
           _per_case(_metric("concavity_filled")), 0.01, "{:.2%}"),
    Target("every noise kind: median bumps left on parts thicker than twice the noise height ≤ 10 %",
           _per_kind_median("bumps_left_over_2h", BUMPS_ONLY + ("bumps-dents",)), 0.10, "{:.1%}"),
    Target("genus equal to the clean shape's on at least half the cases (share differing ≤ 50 %)",
           _genus_share_differing, 0.5, "{:.0%}"),
    Target("another denoise resolution (e.g. 256): noise left within 0.05 of this one on each",
           _resolution_agreement, 0.05, "{:.3f}"),
)


def evaluate(target, pairs):
    """Judge a target on its ``(what, value)`` pairs (None and NaN values do not count).

    Returns
    -------
    dict
        ``status`` (``met``, ``NOT met`` or ``n/a`` without values), ``value`` (the median, or the
        worst value), ``worst`` (what it is), ``over`` (how many values are over the limit) and ``count``.
    """
    pairs = [(what, v) for what, v in pairs if _number(v)]
    if not pairs:
        return {"status": "n/a", "value": None, "worst": None, "over": 0, "count": 0}
    values = np.array([v for _, v in pairs], dtype=float)
    ok = values < target.limit if target.strict else values <= target.limit
    worst = int(np.argmax(values))
    value = float(np.median(values)) if target.median else float(values[worst])
    met = (value < target.limit if target.strict else value <= target.limit) if target.median else bool(ok.all())
    return {"status": "met" if met else "NOT met", "value": value, "worst": pairs[worst][0],
            "over": int((~ok).sum()), "count": len(pairs)}


def acceptance(results, check):
    """Every `TARGETS` entry judged for the variant ``check``, per split: ``{split: [judgement + "target",
    "limit", "format"]}``."""
    out = {}
    for split in SPLITS:
        cases = [c for c in results["cases"] if c["split"] == split]
        if cases:
            out[split] = [{"target": t.text, "limit": t.limit, "format": t.fmt,
                           **evaluate(t, t.values(results, cases, check))} for t in TARGETS]
    return out


# ----------------------------------------------------------------------------------------------- markdown


def _table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows])


def _fmt(fmt, value):
    if not _number(value):
        return "–"
    return "∞ (failed)" if value == math.inf else fmt.format(value)


def _cell(results, case, method):
    if method not in case["methods"]:
        return "–"
    entry = case["methods"][method]
    if entry.get("error") is not None:
        return "failed"
    text = " · ".join(_fmt(SUMMARY_METRICS[k][1], entry.get(k))
                      for k in ("noise_left", "chamfer", "normal_error_deg", "sharp_edge_mean"))
    marks = [mark for key, mark in (("genus", "**g≠**"), ("voxel_genus", "**vg≠**"))
             if not genus_equal(results, case, entry, key)]
    return " ".join([text] + marks)


def case_table(results, split):
    """Rows = the split's cases, columns = the methods (`CELL_LEGEND`)."""
    names = methods(results)
    rows = [[c["name"]] + [_cell(results, c, m) for m in names] for c in results["cases"] if c["split"] == split]
    return _table(["case"] + names, rows)


def summary_table(results, split):
    """Rows = method x noise kind: ``median / max`` of each summary metric, genus counts, time."""
    rows = []
    for method, kinds in results["summary"][split].items():
        for kind, row in kinds.items():
            cells = [" / ".join(_fmt(fmt, row.get(key, {}).get(stat)) for stat in ("median", "max"))
                     for key, (_, fmt) in SUMMARY_METRICS.items()]
            rows.append([method, kind] + cells + [f"{row['genus_equal']}/{row['n']}",
                                                  f"{row['voxel_genus_equal']}/{row['n']}", row["failed"],
                                                  _fmt("{:.1f}", row["seconds_median"])])
    return _table(["method", "noise", *(t for t, _ in SUMMARY_METRICS.values()), "genus = clean",
                   "voxel genus = clean", "failed",
                   "time (s), median"], rows)


def acceptance_table(results, split):
    rows = [[j["target"], j["status"] if j["status"] != "NOT met" else "**NOT met**", _fmt(j["format"], j["value"]),
             j["worst"] or "–", f"{j['over']}/{j['count']}"] for j in results["acceptance"][split]]
    return _table(["target", "status", "median or worst value", "worst", "over the limit"], rows)


def write_table(results, path):
    """Write ``table.md``: per split the case table, the summary and the acceptance block; then the
    clean pass, the shapes and the settings."""
    s = results["settings"]
    check = s["check"]
    out = ["# skelfilter quality benchmark\n",
           f"Noise grid {s['resolution']} voxels along the longest side; rivals on the noisy mesh decimated to "
           f"≤ {s['max_faces']} faces, skelfilter on the marching-cubes mesh. Variants: "
           + "; ".join(f"`{label}` (resolution {p['resolution']})" for label, p in s["variants"].items())
           + f". Held-out shapes: {', '.join(s['held_out'])}. Git commit {s['versions'].get('git commit', '-')}"
           + (f" with uncommitted changes to {', '.join(s['uncommitted'])}" if s.get("uncommitted") else "")
           + ".\n"]
    for split in SPLITS:
        if split not in results["summary"]:
            continue
        cases = [c for c in results["cases"] if c["split"] == split]
        out.append(f"## {split} split ({len(cases)} cases: {', '.join(dict.fromkeys(c['shape'] for c in cases))})\n")
        out.append(f"### Summary ({split})\n")
        out.append("Median / max over the cases; `all` = every noise kind.\n")
        out.append(summary_table(results, split) + "\n")
        out.append(f"### Acceptance of `{check}` ({split})\n")
        out.append(acceptance_table(results, split) + "\n")
        out.append(f"### Cases ({split})\n")
        out.append(f"Cells: {CELL_LEGEND}.\n")
        out.append(case_table(results, split) + "\n")
    if results.get("clean_pass"):
        labels = list(results["clean_pass"])
        shape_names = list(dict.fromkeys(sh for label in labels for sh in results["clean_pass"][label]))
        out.append("## Clean pass: the clean shape through the filter\n")
        out.append("Cells: voxels changed · 99 % of the vertices within (share of the diagonal, the worse "
                   "direction) · volume change · seconds.\n")
        out.append(_table(["shape"] + labels, [[sh] + [_pass_cell(results["clean_pass"][label].get(sh))
                                                       for label in labels] for sh in shape_names]) + "\n")
    out.append("## Shapes\n")
    out.append(_table(["shape", "split", "CAD", "genus (known)", "genus (measured)", "surfaces", "measured on",
                       "voxel genus", "faces"],
                      [[name, f["split"], "yes" if f["cad"] else "no", f["known_genus"], f["genus"],
                        f["components"], f["genus_from"], f["voxel_genus"], f["faces"]]
                       for name, f in results["shapes"].items()])
               + "\n")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out))


def _pass_cell(entry):
    if entry is None:
        return "–"
    if entry.get("error"):
        return "failed"
    distance = max(entry.get("source_to_result", math.nan), entry.get("result_to_source", math.nan))
    return (f"{entry['changed']:.2%} · {distance:.3%} · {entry.get('volume_change', math.nan):.3%} · "
            f"{entry['seconds']:.1f} s")
