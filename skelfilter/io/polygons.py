"""Polygons made triangles inside themselves, as the mesh readers need them (OFF, PLY and OBJ faces of
any number of corners).

A convex polygon is cut into a fan from its first corner; a concave one (an L-shaped cap, a dart) is
cut by ear clipping in its own plane, so no triangle crosses its notch and the surface keeps its area
and the solid its volume.
"""

import numpy as np

from skelfilter.runtime.compiled import njit

# A corner turning back by less than this share of its two edges' lengths (times the polygon's area
# vector) is taken as straight: rounding in the file's digits makes no polygon concave.
_STRAIGHT = 1e-9


def triangulate(vertices, counts, corners):
    """Triangles of polygons given by their numbers of corners and their corners' vertex indices.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3)
    counts : ndarray of int, shape (p,)
        Corners of each polygon (at least 3).
    corners : ndarray of int, shape (counts.sum(),)
        The polygons' vertex indices, one polygon after the other, in their winding order.

    Returns
    -------
    triangles : ndarray of int64, shape (counts.sum() - 2 * p, 3)
        Each polygon's triangles in turn, wound as the polygon.
    polygon : ndarray of int64
        The polygon each triangle comes from (to carry face colours and the like).
    """
    counts = np.asarray(counts, dtype=np.int64)
    corners = np.asarray(corners, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    polygon = np.repeat(np.arange(len(counts)), counts - 2)
    first = np.repeat(starts, counts - 2)
    second = spans(starts + 1, counts - 2)
    triangles = np.stack([corners[first], corners[second], corners[second + 1]], axis=1)
    concave = np.flatnonzero(is_concave(vertices, counts, corners))
    if len(concave):
        triangles = _clip_concave(vertices, counts, corners, starts, concave, triangles)
    return triangles, polygon


def spans(starts, lengths):
    """The indices ``start, start + 1, ..., start + length - 1`` of each span, one span after the other."""
    lengths = np.asarray(lengths, dtype=np.int64)
    return np.repeat(np.asarray(starts, dtype=np.int64) - (np.cumsum(lengths) - lengths), lengths) + \
        np.arange(lengths.sum())


def is_concave(vertices, counts, corners):
    """Whether each polygon (as in `triangulate`) turns back at one of its corners, seen along its area
    vector (Newell's); a triangle never does."""
    all_counts = np.asarray(counts, dtype=np.int64)
    concave = np.zeros(len(all_counts), dtype=bool)
    polygon = np.flatnonzero(all_counts > 3)
    if not len(polygon):
        return concave
    counts = all_counts[polygon]
    corners = np.asarray(corners, dtype=np.int64)[spans((np.cumsum(all_counts) - all_counts)[polygon], counts)]
    starts = np.cumsum(counts) - counts
    points = np.asarray(vertices, dtype=np.float64)[corners]
    owner = np.repeat(np.arange(len(counts)), counts)
    position = np.arange(len(corners)) - starts[owner]
    following = np.where(position == counts[owner] - 1, starts[owner], np.arange(len(corners)) + 1)
    preceding = np.where(position == 0, starts[owner] + counts[owner] - 1, np.arange(len(corners)) - 1)
    normal = np.add.reduceat(np.cross(points, points[following]), starts, axis=0)
    inward, outward = points - points[preceding], points[following] - points
    turn = np.einsum("ij,ij->i", np.cross(inward, outward), normal[owner])
    scale = np.linalg.norm(inward, axis=1) * np.linalg.norm(outward, axis=1) * np.linalg.norm(normal[owner], axis=1)
    concave[polygon[np.unique(owner[turn < -_STRAIGHT * scale])]] = True
    return concave


def _clip_concave(vertices, counts, corners, starts, concave, triangles):
    """``triangles`` with those of the ``concave`` polygons replaced by their ear clipping, done in each
    polygon's plane."""
    sizes = counts[concave]
    take = spans(starts[concave], sizes)
    points = np.asarray(vertices, dtype=np.float64)[corners[take]]
    owner = np.repeat(np.arange(len(concave)), sizes)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    following = np.arange(len(take)) + 1
    following[offsets[1:] - 1] = offsets[:-1]
    normal = np.add.reduceat(np.cross(points, points[following]), offsets[:-1], axis=0)
    normal /= np.maximum(np.linalg.norm(normal, axis=1), np.finfo(float).tiny)[:, None]
    # Two axes in each polygon's plane, so that the polygon winds counter-clockwise in them.
    helper = np.eye(3)[np.argmin(np.abs(normal), axis=1)]
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u, axis=1)[:, None]
    v = np.cross(normal, u)
    flat = np.stack([np.einsum("ij,ij->i", points, u[owner]), np.einsum("ij,ij->i", points, v[owner])], axis=1)
    local = _ear_clip(flat, offsets)
    clipped = corners[take][local + np.repeat(offsets[:-1], sizes - 2)[:, None]]
    first_triangle = starts - 2 * np.arange(len(counts))
    triangles[spans(first_triangle[concave], sizes - 2)] = clipped
    return triangles


@njit()
def _ear_clip(points, offsets):
    """Ear clipping of counter-clockwise 2-D polygons (``points[offsets[i]:offsets[i + 1]]``): each
    polygon's triangles as indices into its own corners, polygon after polygon."""
    total = 0
    for p in range(len(offsets) - 1):
        total += offsets[p + 1] - offsets[p] - 2
    out = np.empty((total, 3), dtype=np.int64)
    row = 0
    for p in range(len(offsets) - 1):
        start, n = offsets[p], offsets[p + 1] - offsets[p]
        left = np.arange(n)
        remaining = n
        while remaining > 3:
            found = -1
            for k in range(remaining):
                a, b, c = left[(k - 1) % remaining], left[k], left[(k + 1) % remaining]
                ax, ay = points[start + a, 0], points[start + a, 1]
                bx, by = points[start + b, 0], points[start + b, 1]
                cx, cy = points[start + c, 0], points[start + c, 1]
                if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) <= 0.0:
                    continue  # a reflex or straight corner is no ear
                inside = False
                for m in range(remaining):
                    q = left[m]
                    if q == a or q == b or q == c:
                        continue
                    qx, qy = points[start + q, 0], points[start + q, 1]
                    if ((bx - ax) * (qy - ay) - (by - ay) * (qx - ax) >= 0.0
                            and (cx - bx) * (qy - by) - (cy - by) * (qx - bx) >= 0.0
                            and (ax - cx) * (qy - cy) - (ay - cy) * (qx - cx) >= 0.0):
                        inside = True
                        break
                if not inside:
                    found = k
                    break
            if found < 0:  # no ear (a polygon crossing itself): the rest as a fan
                found = 0
            out[row, 0] = left[(found - 1) % remaining]
            out[row, 1] = left[found]
            out[row, 2] = left[(found + 1) % remaining]
            row += 1
            left[found:remaining - 1] = left[found + 1:remaining].copy()
            remaining -= 1
        out[row, 0], out[row, 1], out[row, 2] = left[0], left[1], left[2]
        row += 1
    return out
