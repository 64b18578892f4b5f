"""Guided normal filtering (Zhang et al. 2015) against brute force, and the adaptive fine pass."""

import itertools

import numpy as np
import pytest
import trimesh

from skelfilter.core.pipeline import denoise_volume
from skelfilter.errors import ParameterError
from skelfilter.evaluation import metrics
from skelfilter.mesh import fine_pass, guided_filtering, normal_filtering
from skelfilter.mesh import pipeline as mesh_pipeline


def noisy(mesh, level, seed=3):
    rng = np.random.default_rng(seed)
    offset = rng.normal(0.0, level * mesh.edges_unique_length.mean(), len(mesh.vertices))
    return trimesh.Trimesh(mesh.vertices + mesh.vertex_normals * offset[:, None], mesh.faces, process=False)


def fine_box():
    """A box with flat, finely tessellated sides (a coarse box's patches all cross an edge)."""
    box = trimesh.creation.box((1.0, 1.4, 0.8))
    for _ in range(4):
        box = box.subdivide()
    return box


def test_edge_neighbours_match_brute_force():
    mesh = trimesh.creation.icosphere(1)
    faces = mesh.faces
    across = guided_filtering.edge_neighbours(faces)
    for f, k in itertools.product(range(len(faces)), range(3)):
        edge = {faces[f][k], faces[f][(k + 1) % 3]}
        others = [g for g in range(len(faces)) if g != f and edge <= set(faces[g])]
        assert across[f, k] == (others[0] if len(others) == 1 else -1)
    open_mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[1:], process=False)
    assert (guided_filtering.edge_neighbours(open_mesh.faces) == -1).sum() == 3


def test_patch_measures_match_brute_force():
    mesh = noisy(trimesh.creation.icosphere(1), 0.3)
    faces = np.asarray(mesh.faces)
    normals, areas, _ = normal_filtering.face_geometry(mesh.vertices, faces)
    pairs = normal_filtering.face_neighbours(faces, len(mesh.vertices))
    neighbours = guided_filtering.neighbour_lists(pairs, len(faces))
    consistency, spread, mean = guided_filtering.patch_measures(normals, areas, neighbours,
                                                                guided_filtering.edge_neighbours(faces))
    for c in range(len(faces)):
        patch = [c] + [f for f in range(len(faces)) if f != c and set(faces[f]) & set(faces[c])]
        d = max(np.linalg.norm(normals[a] - normals[b]) for a, b in itertools.combinations(patch, 2))
        inner = [np.linalg.norm(normals[a] - normals[b]) for a, b in itertools.combinations(patch, 2)
                 if len(set(faces[a]) & set(faces[b])) == 2]
        assert spread[c] == pytest.approx(d)
        assert consistency[c] == pytest.approx(d * max(inner) / (1e-9 + sum(inner)))
        weighted = (areas[patch, None] * normals[patch]).sum(axis=0)
        assert mean[c] == pytest.approx(weighted / np.linalg.norm(weighted))
    guide = guided_filtering.guidance(normals, areas, neighbours, guided_filtering.edge_neighbours(faces))
    for c in range(len(faces)):
        candidates = [c] + [f for f in range(len(faces)) if f != c and set(faces[f]) & set(faces[c])]
        assert guide[c] == pytest.approx(mean[min(candidates, key=lambda f: consistency[f])])


def test_flat_share_tells_flat_sides_from_a_sphere():
    def share(mesh):
        faces = np.asarray(mesh.faces)
        normals, areas, _ = normal_filtering.face_geometry(mesh.vertices, faces)
        neighbours = guided_filtering.neighbour_lists(normal_filtering.face_neighbours(faces, len(mesh.vertices)),
                                                      len(faces))
        return guided_filtering.flat_share(normals, areas, neighbours, guided_filtering.edge_neighbours(faces))

    assert share(fine_box()) > 0.5
    assert share(trimesh.creation.icosphere(3)) == 0.0


def test_the_adaptive_pass_sharpens_a_box_and_leaves_a_sphere_to_the_bilateral_filter():
    box = fine_box()
    rough = noisy(box, 0.3)
    scores = {}
    for name in fine_pass.NORMAL_FILTERS:
        vertices, _ = fine_pass.fine_pass(rough.vertices, rough.faces, normal_filter=name)
        scores[name] = metrics.literature_errors(trimesh.Trimesh(vertices, box.faces, process=False), box)
    assert scores["adaptive"].theta < 0.8 * scores["bilateral"].theta
    assert scores["adaptive"].e_v < scores["bilateral"].e_v
    sphere = trimesh.creation.icosphere(3)
    rough = noisy(sphere, 0.3)
    adaptive, _ = fine_pass.fine_pass(rough.vertices, rough.faces)
    bilateral, _ = fine_pass.fine_pass(rough.vertices, rough.faces, normal_filter="bilateral")
    assert np.array_equal(adaptive, bilateral)


def test_the_rounds_sharpen_a_piecewise_flat_shape_further(monkeypatch):
    assert fine_pass.guided_rounds(0.0) == 2 and fine_pass.guided_rounds(1.0) == 4
    box = fine_box()
    rough = noisy(box, 0.5)  # a guided weight of 1
    with_rounds, _ = fine_pass.fine_pass(rough.vertices, rough.faces)
    monkeypatch.setattr(fine_pass, "GUIDED_ROUNDS", (0, 0))
    without, _ = fine_pass.fine_pass(rough.vertices, rough.faces)
    scores = [metrics.literature_errors(trimesh.Trimesh(v, box.faces, process=False), box)
              for v in (with_rounds, without)]
    assert scores[0].theta < 0.8 * scores[1].theta and scores[0].e_v < scores[1].e_v


def test_an_unknown_normal_filter_is_refused():
    box = trimesh.creation.box()
    with pytest.raises(ValueError, match="normal_filter must be one of adaptive, bilateral"):
        fine_pass.fine_pass(box.vertices, box.faces, normal_filter="guided")


def test_normal_filter_takes_effect_on_meshes_and_is_refused_for_volumes():
    box = fine_box()
    rough = noisy(box, 0.3)
    adaptive = mesh_pipeline.denoise_mesh(rough)
    bilateral = mesh_pipeline.denoise_mesh(rough, normal_filter="bilateral")
    assert metrics.literature_errors(adaptive, box).theta < 0.8 * metrics.literature_errors(bilateral, box).theta
    volume = np.zeros((24, 24, 24), bool)
    volume[4:20, 4:20, 4:20] = True
    with pytest.raises(ParameterError, match="`normal_filter` is for meshes"):
        denoise_volume(volume, normal_filter="bilateral")
