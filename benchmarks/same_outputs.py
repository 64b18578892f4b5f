"""Whether a change leaves every output as it was: the outputs on a corpus, saved by one commit and
compared bit for bit with another's.

    PYTHONPATH=. python -m benchmarks.same_outputs save OUT.npz [--corpus routing shapes volumes presets]
    python -m benchmarks.same_outputs compare BEFORE.npz AFTER.npz

``save`` denoises, with the skelfilter that ``PYTHONPATH`` (or the installed package) gives, every case
of the corpora named: ``routing`` the routing corpus (`routing_corpus.CASES`, 112 meshes: clean, fine
noise, skeleton-scale noise), ``shapes`` every quality-benchmark shape with one of two noises at 128
voxels, ``volumes`` fandisk's and the rocker arm's noisy voxels at 128 through `denoise_volume` and a
two-label map's surfaces (all through the default), ``presets`` the thesis presets (``thesis``,
``thesis-tuned``) on fandisk, the bunny and the chair with the thesis' bumps and dents at 96 voxels, as
volumes and as meshes; meshes are saved as vertices and faces, volumes as mask and field. A case
that fails is saved as its error's text. ``compare`` prints every array that differs (and by how
much) and exits 1 if any does. The meshes of the corpora come from this checkout's ``benchmarks``
(cached, and read back from the cache on the first run too), so two commits denoise the same inputs; run
each commit from its own checkout's root.
"""

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CORPORA = ("routing", "shapes", "volumes", "presets")
SHAPE_NOISES = (("high", {"p": 0.01, "r": 2.1, "h": 7, "l": 4}),
                ("bumps-dents", {"p": 0.014, "r": 2.1, "h": 3, "l": 6, "dents": True}))


def _routing():
    from benchmarks import routing_corpus

    for name in routing_corpus.CASES:
        yield name, lambda name=name: ("mesh", routing_corpus.load(name)[0])


def _shapes():
    from benchmarks import shapes
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    for i, name in enumerate(shapes.SHAPES):
        kind, noise = SHAPE_NOISES[i % 2]
        yield f"{name}-{kind}", lambda name=name, noise=noise: (
            "mesh", mesh_pipeline.noisy_mesh(shapes.load(name), NoiseParams(resolution=128, seed=1, **noise))[0])


def _volumes():
    from benchmarks import shapes
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    for name in ("fandisk", "rocker-arm"):
        yield f"volume-{name}", lambda name=name: (
            "volume", mesh_pipeline.noisy_mesh(shapes.load(name), NoiseParams(resolution=128, seed=1))[1].noisy)
    i, j, k = np.indices((40, 44, 36))
    labels = np.zeros(i.shape, np.int16)
    labels[(i - 20) ** 2 + (j - 22) ** 2 + (k - 18) ** 2 < 15**2] = 1
    labels[(i - 20) ** 2 + (j - 22) ** 2 < 4**2] = 2
    yield "label-map", lambda: ("labels", labels)


def _presets():
    from benchmarks import shapes
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    for name in ("fandisk", "bunny", "chair"):
        noisy = lambda name=name: mesh_pipeline.noisy_mesh(  # noqa: E731
            shapes.load(name), NoiseParams(resolution=96, seed=1, dents=True))
        for preset in ("thesis", "thesis-tuned"):
            yield f"{name}-{preset}-volume", lambda noisy=noisy, preset=preset: (
                "volume", noisy()[1].noisy, {"preset": preset})
            yield f"{name}-{preset}-mesh", lambda noisy=noisy, preset=preset: (
                "mesh", noisy()[0], {"preset": preset, "resolution": 96})


def _outputs(kind, data, params=None):
    """The arrays an input's output is compared by: the default's, or with ``params`` (a dict of fields)."""
    params = params or {}
    if kind == "mesh":
        from skelfilter.mesh import pipeline as mesh_pipeline

        out = mesh_pipeline.denoise_mesh(data, **params)
        return {"v": np.asarray(out.vertices), "f": np.asarray(out.faces)}
    if kind == "volume":
        from skelfilter.core.pipeline import denoise_volume

        result = denoise_volume(data, **params)
        return {"mask": result.mask, "field": result.field}
    from skelfilter.mesh import marching_cubes

    meshes = marching_cubes.labels_to_world_meshes(data, np.diag([0.7, 0.7, 2.0, 1.0]))
    return {f"{label}.{part}": np.asarray(getattr(mesh, attribute))
            for label, mesh in meshes.items() for part, attribute in (("v", "vertices"), ("f", "faces"))}


def save(path, corpora):
    import skelfilter

    arrays, start = {}, time.perf_counter()
    cases = {"routing": _routing, "shapes": _shapes, "volumes": _volumes, "presets": _presets}
    for corpus in corpora:
        for name, make in cases[corpus]():
            try:
                outputs = _outputs(*make())
            except Exception as exc:  # a failure is an output too, compared by its text
                outputs = {"error": np.array(f"{type(exc).__name__}: {exc}"[:300])}
            arrays.update({f"{corpus}/{name}/{key}": value for key, value in outputs.items()})
            print(f"  {corpus}/{name}", file=sys.stderr)
    np.savez_compressed(path, **arrays)
    print(f"{len(arrays)} arrays from {os.path.dirname(skelfilter.__file__)} in "
          f"{time.perf_counter() - start:.0f} s -> {path}")


def compare(before, after):
    """Names and differences of the arrays that are not the same; [] when every one is."""
    a, b = np.load(before), np.load(after)
    differ = []
    for key in sorted(set(a.files) | set(b.files)):
        if key not in a.files or key not in b.files:
            differ.append(f"{key}: only in {before if key in a.files else after}")
            continue
        x, y = a[key], b[key]
        if x.shape != y.shape:
            differ.append(f"{key}: shape {x.shape} -> {y.shape}")
        elif not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            gap = float(np.max(np.abs(x.astype(float) - y.astype(float)))) if x.dtype.kind in "biuf" else "text"
            differ.append(f"{key}: {np.count_nonzero(x != y)} of {x.size} values differ (largest {gap})")
    return differ


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    to_save = commands.add_parser("save", help="denoise the corpora, save the outputs")
    to_save.add_argument("out")
    to_save.add_argument("--corpus", nargs="+", choices=CORPORA, default=list(CORPORA))
    to_compare = commands.add_parser("compare", help="compare two saved runs bit for bit")
    to_compare.add_argument("before")
    to_compare.add_argument("after")
    args = parser.parse_args(argv)
    if args.command == "save":
        save(args.out, args.corpus)
        return 0
    differ = compare(args.before, args.after)
    for line in differ:
        print(line)
    print("identical" if not differ else f"{len(differ)} arrays differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
