"""``report.html`` and ``report.md`` from the comparison's results (pictures beside them).

Both carry: the headline table, the picture grids (overview, sharp-edge close-up, distance colour
map; rows = models, columns = methods), one metric table per model with the best value of each column
marked (among the filters: the noisy and clean references do not compete), failures with their
reason, the threshold sweep, timings, parameters and versions.
"""

import html
import math
import os

from skelfilter.evaluation.comparison import render
from skelfilter.meshlab.scripts import read_filter_script
from skelfilter.runtime.extras import need

# metric key -> (column title, +1 if higher is better, -1 if lower, format)
METRICS = {
    "noise_removed": ("noise removed", +1, "{:.1%}"),
    "bumps_removed": ("bumps removed", +1, "{:.1%}"),
    "dents_removed": ("dents filled", +1, "{:.1%}"),
    "chamfer": ("Chamfer (vox)", -1, "{:.3f}"),
    "hausdorff_95": ("Hausdorff 95% (vox)", -1, "{:.2f}"),
    "hausdorff_max": ("Hausdorff max (vox)", -1, "{:.2f}"),
    "normal_error_deg": ("normal error (°)", -1, "{:.1f}"),
    "theta_deg": ("θ, the literature's (°)", -1, "{:.1f}"),
    "iou": ("IoU", +1, "{:.4f}"),
    "shrinkage": ("clean lost", -1, "{:.2%}"),
    "sharp_edge_mean": ("sharp-edge error (vox)", -1, "{:.2f}"),
    "sharp_edge_max": ("sharp-edge max (vox)", -1, "{:.2f}"),
    # with no clean mesh: what each filter did to the input (`metrics.change_measures`); none is better
    "roughness_deg": ("roughness (°)", 0, "{:.1f}"),
    "moved_mean": ("moved, mean (vox)", 0, "{:.3f}"),
    "moved_max": ("moved, max (vox)", 0, "{:.2f}"),
    "normal_change_deg": ("normals turned (°)", 0, "{:.1f}"),
    "volume_change": ("volume change", 0, "{:+.2%}"),
    "watertight": ("watertight", 0, "{}"),
    "edge_manifold": ("manifold", 0, "{}"),
    "faces": ("faces", 0, "{}"),
    "seconds": ("time (s)", -1, "{:.1f}"),
}
HEADLINE = ("noise_removed", "chamfer", "normal_error_deg", "sharp_edge_mean", "roughness_deg", "moved_mean",
            "volume_change", "seconds")
REFERENCE_KINDS = ("noisy", "clean")
PICTURES = (("view", "Overview"), ("closeup", "Close-up"),
            ("colormap", "Distance to the clean surface (with no clean mesh: to the input)"))


def _value(entry, key):
    value = entry["seconds"] if key == "seconds" else entry.get("metrics", {}).get(key)
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def _best(entries, key):
    """Names of the filters holding the best value of ``key`` (ties included)."""
    sense = METRICS[key][1]
    values = [(e["name"], _value(e, key)) for e in entries
              if e["kind"] not in REFERENCE_KINDS and e["error"] is None and _value(e, key) is not None]
    if sense == 0 or not values:
        return set()
    top = max(v * sense for _, v in values)
    return {name for name, v in values if v * sense == top}


def _columns(case, keys=tuple(METRICS)):
    """Those of ``keys`` that have a value for at least one method of the case."""
    return [k for k in keys if any(_value(e, k) is not None for e in case["methods"] if e["error"] is None)]


def headline_keys(results):
    """The HEADLINE columns that have a value in some case."""
    found = {k for case in results["cases"] for k in _columns(case, HEADLINE)}
    return [k for k in HEADLINE if k in found]


def table_rows(case, keys):
    """(method name, [(text, is_best)], error) per method of a case."""
    best = {k: _best(case["methods"], k) for k in keys}
    rows = []
    for e in case["methods"]:
        if e["error"] is not None:
            rows.append((e["name"], [], e["error"]))
            continue
        cells = []
        for k in keys:
            v = _value(e, k)
            cells.append(("–" if v is None else METRICS[k][2].format(v), e["name"] in best[k]))
        rows.append((e["name"], cells, None))
    return rows


def _script_parameters(config):
    out = []
    for m in config["methods"]:
        if m["kind"] == "meshlab":
            for name, params in read_filter_script(m["script"]):
                out.append((m["name"], f"{name}({', '.join(f'{k}={v!r}' for k, v in params.items())}) "
                                       f"from {os.path.basename(m['script'])}"))
        elif m["params"]:
            out.append((m["name"], ", ".join(f"{k} = {v!r}" for k, v in m["params"].items())))
        elif m["kind"] in ("skelfilter", "meshlib"):
            out.append((m["name"], "defaults"))
    return out


def _noise_text(case):
    if not case["synthetic"]:
        return ("given noisy/clean pair" if case.get("reference", "clean") == "clean" else
                "given mesh, no clean one: each filter measured against the input")
    n = case["noise"]
    return (f"p = {n['p']}, r = {n['r']}, h = {n['h']}, l = {n['l']}" + (", with dents" if n["dents"] else "")
            + f"; seed {n['seed']}, {n['resolution']} voxels")


def _sweep_plot(sweep, out_dir):
    from matplotlib.figure import Figure

    t = [r["t"] for r in sweep["rows"]]
    fig = Figure(figsize=(6.0, 3.6), dpi=110)
    ax = fig.subplots()
    ax.plot(t, [r["reconstruction_error"] for r in sweep["rows"]], "o-", label="reconstruction error ε̂ (eq. 6.5)")
    ax.plot(t, [1 - r["bumps_removed"] for r in sweep["rows"]], "s--", label="bump voxels left")
    if any(not math.isnan(r["dents_filled"]) for r in sweep["rows"]):
        ax.plot(t, [1 - r["dents_filled"] for r in sweep["rows"]], "^--", label="dent voxels left")
    ax.plot(t, [r["clean_lost"] for r in sweep["rows"]], "d:", label="clean volume lost")
    ax.set_xlabel("threshold t (voxels)")
    ax.set_ylabel("share")
    ax.set_title(f"skelfilter on {sweep['case']}: error against t")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(out_dir, "sweep.png")
    fig.savefig(path)
    return "sweep.png"


def headline_rows(results):
    """(case, method, [texts]) for the headline table (`headline_keys` columns)."""
    rows = []
    for case in results["cases"]:
        for name, cells, error in table_rows(case, headline_keys(results)):
            rows.append((case["name"], name, [f"failed: {error}"] if error else
                         [f"**{text}**" if best else text for text, best in cells]))
    return rows


# ----------------------------------------------------------------------------------------------- markdown


def _md_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _intro(results):
    """What was compared, and how to read the tables."""
    cfg = results["config"]
    source = (f"Configuration {cfg['path']}" if cfg["path"] else
              "The meshes given, each as it is: skelfilter's default beside MeshLab's filters")
    models = len(results["cases"])
    return (f"{source}; {models} model{'s' if models != 1 else ''}; wall time {results['wall_seconds']:.0f} s. "
            f"Distances are in voxels of each model's grid ({cfg['resolution']} voxels along the longest side). "
            "Marked: the best filter in a column; the input and the clean mesh are references and do not "
            "compete. With no clean mesh only the time is marked: roughness, how far the surface moved and "
            "how much the volume changed say what a filter did, not whether it was right.")


def _markdown(results, sweep_png):
    cfg, out = results["config"], []
    out.append("# skelfilter against MeshLab's filters\n")
    out.append(_intro(results) + "\n")
    out.append("## Headline\n")
    out.append(_md_table(["model", "method"] + [METRICS[k][0] for k in headline_keys(results)],
                         [[c, m] + cells for c, m, cells in headline_rows(results)]) + "\n")
    methods = [m["name"] for m in cfg["methods"]]
    for kind, title in PICTURES:
        out.append(f"## {title}\n")
        rows = []
        for case in results["cases"]:
            cells = [case["name"]]
            for e in case["methods"]:
                cells.append(f"![{e['name']}]({e['images'][kind]})" if "images" in e else "failed")
            rows.append(cells)
        out.append(_md_table(["model"] + methods, rows) + "\n")
        if kind == "colormap":
            out.append("![colour scale](colour-scale.png)\n")
    out.append("## Metrics per model\n")
    for case in results["cases"]:
        keys = _columns(case)
        out.append(f"### {case['name']} ({_noise_text(case)}; close-up: {_closeup_text(case)})\n")
        rows = [[name] + ([f"failed: {error}"] + [""] * (len(keys) - 1) if error else
                          [f"**{t}**" if b else t for t, b in cells]) for name, cells, error in table_rows(case, keys)]
        out.append(_md_table(["method"] + [METRICS[k][0] for k in keys], rows) + "\n")
        out.extend(f"- what {name} ran: {route}\n" for name, route in _routes(case))
    if sweep_png:
        out.append(f"## Threshold sweep ({results['sweep']['case']})\n\n![sweep]({sweep_png})\n")
        out.append(_md_table(["t", "ε̂", "bumps removed", "dents filled", "clean lost", "time (s)"],
                             [[f"{r['t']:g}", f"{r['reconstruction_error']:.4f}", f"{r['bumps_removed']:.1%}",
                               "–" if math.isnan(r["dents_filled"]) else f"{r['dents_filled']:.1%}",
                               f"{r['clean_lost']:.2%}", f"{r['seconds']:.1f}"] for r in results["sweep"]["rows"]])
                   + "\n")
    out.append("## Parameters and versions\n")
    out.append(_md_table(["method", "parameters"], _script_parameters(cfg)) + "\n")
    out.append(_md_table(["model", "noise", "noisy mesh"], [[c["name"], _noise_text(c), _facts_text(c)]
                                                             for c in results["cases"]]) + "\n")
    out.append(_md_table(["package", "version"], sorted(results["versions"].items())) + "\n")
    return "\n".join(out)


def _routes(case):
    """(method, what it ran and why) of the skelfilter methods of a case."""
    return [(e["name"], e["route"]) for e in case["methods"] if e.get("route")]


def _closeup_text(case):
    return case.get("closeup", "a sharp edge")


def _facts_text(case):
    f = case["facts"]
    if "marching_cubes_faces" not in f:
        return f"{f['faces']} faces"
    return (f"{f['faces']} faces (marching cubes {f['marching_cubes_faces']}, decimated: Chamfer "
            f"{f['decimation_chamfer']:.3f}, Hausdorff 95% {f['decimation_hausdorff_95']:.2f} vox); "
            f"{f['bump_voxels']} bump and {f['dent_voxels']} dent voxels")


# ----------------------------------------------------------------------------------------------- html

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
td.best { font-weight: bold; background: #e3f4e1; }
td.failed { color: #a00; text-align: left; }
table.grid td { padding: 2px; text-align: center; vertical-align: middle; }
table.grid img { width: 210px; display: block; }
.note { color: #555; max-width: 70em; }
"""

_SCRIPT = """
window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  document.body.dataset.imagesTotal = imgs.length;
  document.body.dataset.imagesLoaded = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
});
"""


def _h(text):
    return html.escape(str(text))


def _html_table(header, rows, cls=""):
    out = [f"<table class='{cls}'><tr>" + "".join(f"<th>{_h(h)}</th>" for h in header) + "</tr>"]
    out += ["<tr>" + "".join(row) + "</tr>" for row in rows]
    return "\n".join(out) + "</table>"


def _metric_rows(case, keys):
    rows = []
    for name, cells, error in table_rows(case, keys):
        if error:
            rows.append([f"<td>{_h(name)}</td>", f"<td class='failed' colspan='{len(keys)}'>failed: {_h(error)}</td>"])
        else:
            rows.append([f"<td>{_h(name)}</td>"] + [f"<td class='{'best' if b else ''}'>{_h(t)}</td>"
                                                   for t, b in cells])
    return rows


def _html(results, sweep_png):
    cfg = results["config"]
    methods = [m["name"] for m in cfg["methods"]]
    headline = headline_keys(results)
    body = ["<h1>skelfilter against MeshLab's filters</h1>", f"<p class='note'>{_h(_intro(results))}</p>",
            "<h2>Headline</h2>"]
    rows = []
    for case in results["cases"]:
        for name, cells, error in table_rows(case, headline):
            lead = [f"<td>{_h(case['name'])}</td>", f"<td>{_h(name)}</td>"]
            rows.append(lead + ([f"<td class='failed' colspan='{len(headline)}'>failed: {_h(error)}</td>"] if error
                                else [f"<td class='{'best' if b else ''}'>{_h(t)}</td>" for t, b in cells]))
    body.append(_html_table(["model", "method"] + [METRICS[k][0] for k in headline], rows))
    for kind, title in PICTURES:
        body.append(f"<h2>{_h(title)}</h2>")
        if kind == "colormap":
            body.append("<p><img src='colour-scale.png' alt='colour scale' style='width:420px'></p>")
        rows = []
        for case in results["cases"]:
            cells = [f"<td>{_h(case['name'])}</td>"]
            for e in case["methods"]:
                cells.append(f"<td><img src='{_h(e['images'][kind])}' alt='{_h(case['name'])}: {_h(e['name'])}'></td>"
                             if "images" in e else f"<td class='failed'>failed: {_h(e['error'])}</td>")
            rows.append(cells)
        body.append(_html_table(["model"] + methods, rows, "grid"))
    body.append("<h2>Metrics per model</h2>")
    for case in results["cases"]:
        keys = _columns(case)
        body.append(f"<h3>{_h(case['name'])}</h3><p class='note'>{_h(_noise_text(case))}; noisy mesh: "
                    f"{_h(_facts_text(case))}; close-up: {_h(_closeup_text(case))}</p>")
        body.append(_html_table(["method"] + [METRICS[k][0] for k in keys], _metric_rows(case, keys)))
        body.extend(f"<p class='note'>what {_h(name)} ran: {_h(route)}</p>" for name, route in _routes(case))
    if sweep_png:
        body.append(f"<h2>Threshold sweep ({_h(results['sweep']['case'])})</h2>"
                    f"<p><img src='{sweep_png}' alt='error against t'></p>")
        rows = [[f"<td>{r['t']:g}</td>", f"<td>{r['reconstruction_error']:.4f}</td>",
                 f"<td>{r['bumps_removed']:.1%}</td>",
                 f"<td>{'–' if math.isnan(r['dents_filled']) else format(r['dents_filled'], '.1%')}</td>",
                 f"<td>{r['clean_lost']:.2%}</td>", f"<td>{r['seconds']:.1f}</td>"] for r in results["sweep"]["rows"]]
        body.append(_html_table(["t (vox)", "ε̂", "bumps removed", "dents filled", "clean lost", "time (s)"], rows))
    body.append("<h2>Parameters and versions</h2>")
    body.append(_html_table(["method", "parameters"], [[f"<td>{_h(a)}</td>", f"<td>{_h(b)}</td>"]
                                                       for a, b in _script_parameters(cfg)]))
    body.append(_html_table(["model", "noise", "noisy mesh"],
                            [[f"<td>{_h(c['name'])}</td>", f"<td>{_h(_noise_text(c))}</td>",
                              f"<td>{_h(_facts_text(c))}</td>"] for c in results["cases"]]))
    body.append(_html_table(["package", "version"], [[f"<td>{_h(k)}</td>", f"<td>{_h(v)}</td>"]
                                                     for k, v in sorted(results["versions"].items())]))
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>skelfilter comparison</title>"
            f"<style>{_STYLE}</style><script>{_SCRIPT}</script></head><body>" + "\n".join(body) + "</body></html>")


def grid_picture(results, out_dir, kind="view", cell=(210, 170)):
    """One PNG of a picture grid with model and method labels (``grid-<kind>.png``), for READMEs."""
    need("PIL", "the comparison's picture sheet")
    from PIL import Image, ImageDraw, ImageFont

    methods = [m["name"] for m in results["config"]["methods"]]
    left, top = 150, 30
    sheet = Image.new("RGB", (left + cell[0] * len(methods), top + cell[1] * len(results["cases"])), "white")
    draw, font = ImageDraw.Draw(sheet), ImageFont.load_default(size=15)
    for j, name in enumerate(methods):
        draw.text((left + j * cell[0] + cell[0] // 2, top // 2), name, fill="black", font=font, anchor="mm")
    for i, case in enumerate(results["cases"]):
        y = top + i * cell[1]
        draw.text((6, y + cell[1] // 2), case["name"].replace(", ", ",\n").replace(" (", "\n("), fill="black",
                  font=font, anchor="lm")
        for j, e in enumerate(case["methods"]):
            if "images" in e:
                with Image.open(os.path.join(out_dir, e["images"][kind])) as img:
                    sheet.paste(img.convert("RGB").resize(cell), (left + j * cell[0], y))
            else:
                draw.text((left + j * cell[0] + 10, y + cell[1] // 2), "failed", fill="#a00", font=font)
    name = f"grid-{kind}.png"
    sheet.save(os.path.join(out_dir, name))
    return name


def write_report(results, out_dir, colour_range):
    """Write ``report.html``, ``report.md``, the colour scale and the sweep plot into ``out_dir``."""
    render.colour_bar(os.path.join(out_dir, "colour-scale.png"), colour_range,
                      "distance to the clean surface, or to the input with no clean mesh (voxels)")
    sweep_png = _sweep_plot(results["sweep"], out_dir) if results.get("sweep") else None
    for kind, _ in PICTURES:
        grid_picture(results, out_dir, kind)
    for name, text in (("report.md", _markdown(results, sweep_png)), ("report.html", _html(results, sweep_png))):
        tmp = os.path.join(out_dir, f".{name}.tmp")
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, os.path.join(out_dir, name))
