"""The tables of ``docs/comparison.md`` from a ``skelfilter compare`` run's ``results.json``.

    skelfilter compare --out comparison-output
    python -m benchmarks.comparison_tables comparison-output/results.json

One table per measure (models as columns, methods as rows, the best filter in bold; the noisy input
and the clean mesh are references and do not compete), then what skelfilter ran on each model.
"""

import argparse
import json
import math

MEASURES = (  # key, title, scale, digits, lower is better
    ("noise_removed", "noise removed (↑)", 100.0, 0, False),
    ("chamfer", "Chamfer, voxels (↓)", 1.0, 2, True),
    ("normal_error_deg", "mean normal error, degrees (↓)", 1.0, 0, True),
    ("sharp_edge_mean", "sharp-edge error, voxels (↓)", 1.0, 2, True),
    # with no clean mesh (`skelfilter compare MESH`): what each filter did, nothing best
    ("roughness_deg", "roughness, degrees", 1.0, 1, None),
    ("moved_mean", "moved, mean, voxels", 1.0, 3, None),
    ("moved_max", "moved, max, voxels", 1.0, 2, None),
    ("volume_change", "volume change", 100.0, 2, None),
)
REFERENCES = ("noisy", "clean")


def _value(entry, key):
    value = (entry.get("metrics") or {}).get(key)
    return None if value is None or (isinstance(value, float) and math.isnan(value)) else value


def table(results, key, title, scale, digits, lower):
    cases = results["cases"]
    methods = [m["name"] for m in cases[0]["methods"] if m["name"] != "clean"]
    lines = [f"| {title} | " + " | ".join(c["name"] for c in cases) + " |", "|---|" + "---|" * len(cases)]
    best = {}
    for c in cases:
        values = [_value(m, key) for m in c["methods"] if m["kind"] not in REFERENCES]
        values = [v for v in values if v is not None]
        best[c["name"]] = (min if lower else max)(values) if values and lower is not None else None
    for name in methods:
        cells = []
        for c in cases:
            entry = next(m for m in c["methods"] if m["name"] == name)
            value = _value(entry, key)
            if value is None:
                cells.append("–" if entry["error"] is None else "failed")
                continue
            text = f"{value * scale:.{digits}f}" + ("%" if scale == 100.0 else "")
            competes = entry["kind"] not in REFERENCES
            cells.append(f"**{text}**" if competes and value == best[c["name"]] else text)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results")
    args = parser.parse_args(argv)
    with open(args.results) as f:
        results = json.load(f)
    print(f"wall time {results['wall_seconds']:.0f} s\n")
    for measure in MEASURES:
        if any(_value(m, measure[0]) is not None for c in results["cases"] for m in c["methods"]):
            print(table(results, *measure) + "\n")
    for c in results["cases"]:
        for m in c["methods"]:
            if m.get("route"):
                print(f"- {c['name']}, {m['name']}: {m['route']}")


if __name__ == "__main__":
    main()
