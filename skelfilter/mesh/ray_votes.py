"""Mesh to occupancy volume, robust to open and unmerged meshes.

A voxel is inside when its centre is inside the mesh, as told by ray-parity
votes along the three axes: one ray per grid line, whose crossings with the
triangles are found by rasterizing each triangle's projection onto the
lattice of rays. A closed, consistently oriented mesh is voxelized by its
winding number (the nonzero rule): the voxels where the signed count of the
crossings before them is not zero are inside, so parts that overlap or pass
through each other give their union. Any other mesh is voxelized by parity:
the voxels between the 1st and 2nd, 3rd and 4th, ... crossings are inside
for that axis, and a ray with an odd number of crossings went through a hole
and does not vote. Parity needs only the surface's geometry, so a triangle
soup (duplicated seam vertices, no shared topology, any winding) voxelizes
like the merged mesh.
"""

import numpy as np
from numba import prange

from skelfilter.core.neighbourhood import OFFSETS_6
from skelfilter.mesh.welding import weld
from skelfilter.runtime.compiled import njit

# Voxel centres are sampled at this tiny irrational offset (in voxels), the
# same for the three axes: rays then practically never meet a triangle edge
# or vertex, and a centre lying on the surface gets one answer from all axes.
_NUDGE = 1e-6 * np.sqrt([2.0, 3.0, 5.0])

# Voxel states between the votes and the occupancy; bit 0 means inside.
_OUT, _IN = 0, 1  # three valid rays, unanimous
_WEAK_OUT, _WEAK_IN = 2, 3  # any other majority of valid rays, or settled along the rays
_UNDECIDED = 4  # a tie, or fewer than two valid rays



def is_consistently_oriented(vertices, faces):
    """True when the mesh, its vertices merged where they coincide, is closed and consistently
    oriented: every directed edge is used once and its reverse once.

    Such a mesh has a winding number everywhere, which voxelizes overlapping parts as their union.
    """
    _, index = weld(vertices)
    f = index.reshape(-1)[faces]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]
    if len(f) == 0:
        return False
    n = int(f.max()) + 1
    tail, head = f.reshape(-1), np.roll(f, -1, axis=1).reshape(-1)
    edges = np.sort(tail * n + head)
    if (edges[1:] == edges[:-1]).any():
        return False
    reverse = np.sort(head * n + tail)
    return bool(np.array_equal(edges, reverse))


def occupancy(vertices, faces, grid):
    """Occupancy of the triangles (``vertices``, ``faces``) on ``grid``: see `voxelize_on_grid`."""
    winding = is_consistently_oriented(vertices, faces)
    # Per vertex, not per triangle corner: the same values in a third of the memory.
    local = grid.to_index(vertices) - _NUDGE
    votes = np.zeros(grid.shape, dtype=np.uint8)
    rays, valid = [], []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        nu, nv = grid.shape[u], grid.shape[v]
        us, vs, ws = local[:, u], local[:, v], local[:, axis]
        # Counting sort of the crossings by ray: count them, then write each
        # one at its ray's next free slot.
        counts = np.zeros(nu * nv, dtype=np.int64)
        # (u, v, w) is right-handed for the x and z rays, left-handed for the y rays.
        handedness = -1 if axis == 1 else 1
        _scan(us, vs, ws, faces, nu, nv, counts, np.empty(0), np.empty(0, np.int8), handedness)
        start = np.zeros(nu * nv + 1, dtype=np.int64)
        np.cumsum(counts, out=start[1:])
        hits = np.empty(start[-1])
        signs = np.empty(start[-1], dtype=np.int8)
        _scan(us, vs, ws, faces, nu, nv, start[:-1].copy(), hits, signs, handedness)
        ok = np.ones(nu * nv, dtype=np.bool_)
        _vote(hits, signs, start, np.moveaxis(votes, axis, -1), np.uint8(1 << axis), ok, winding)
        del signs
        rays.append((hits, start))
        valid.append(ok.reshape(nu, nv))
    _decide(votes, *valid)
    flat = votes.reshape(-1)
    undecided = np.flatnonzero(flat == _UNDECIDED)
    if undecided.size:
        score = np.zeros(undecided.size)
        for axis, (hits, start) in enumerate(rays):
            view = np.moveaxis(votes, axis, -1)
            _stretch_score(view, hits, start, np.array(view.strides), undecided, score)
        flat[undecided] = np.where(score > 0, _WEAK_IN, _WEAK_OUT)
    weak = np.flatnonzero(flat >= _WEAK_OUT)
    if weak.size:
        _seal(votes, weak)
    return votes.view(np.bool_)


@njit()
def _clip(x, n):
    # Clipped in floating point: a far-away triangle's coordinates may not fit an int.
    return int(min(max(x, 0.0), float(n)))


@njit()
def _orient(ax, ay, bx, by, px, py):
    # Twice the signed area of (a, b, p) with a, b taken in lexicographic
    # order: the triangles sharing an edge see bit-identical values at a ray
    # next to it, so rounding never lets both or neither claim the ray.
    if ax > bx or (ax == bx and ay > by):
        ax, ay, bx, by = bx, by, ax, ay
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


@njit()
def _scan(us, vs, ws, faces, nu, nv, slot, hits, signs, handedness):
    """Rasterize every triangle's projection onto the lattice of rays.

    ``us``, ``vs``, ``ws`` are the vertices' coordinates across (u, v) and
    along (w) the rays; ``faces`` index them.

    Ray ``(p, q)`` runs at ``(u, v) = (p, q)``. For each crossing,
    ``slot[ray]`` is incremented; when ``hits`` is not empty the crossing's
    coordinate along the ray is first stored at ``hits[slot[ray]]``, and at
    ``signs[slot[ray]]`` +1 where the triangle faces along the ray, -1 where
    it faces against it (``handedness`` -1 when (u, v, w) is left-handed).
    """
    fill = hits.size > 0
    for f in range(faces.shape[0]):
        i0, i1, i2 = faces[f, 0], faces[f, 1], faces[f, 2]
        ax, bx, cx = us[i0], us[i1], us[i2]
        ay, by, cy = vs[i0], vs[i1], vs[i2]
        # Which side of each edge (bc, ca, ab) the triangle lies on.
        sa = np.sign(_orient(bx, by, cx, cy, ax, ay))
        sb = np.sign(_orient(cx, cy, ax, ay, bx, by))
        sc = np.sign(_orient(ax, ay, bx, by, cx, cy))
        if sa == 0 or sb == 0 or sc == 0:
            continue  # projects to a segment: parallel to the rays
        # A ray exactly on an edge's line is decided as if moved by (d**2, d),
        # d -> 0+: onto the positive side of the edge, or the negative side if
        # the edge is parallel to v. One move for all edges, so a ray through
        # a shared edge or vertex is claimed by exactly one triangle.
        ta = sa == (1 if bx != cx else -1)
        tb = sb == (1 if cx != ax else -1)
        tc = sc == (1 if ax != bx else -1)
        facing = handedness if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) > 0 else -handedness
        p0 = _clip(np.ceil(min(ax, bx, cx)), nu)
        p1 = _clip(np.floor(max(ax, bx, cx)) + 1, nu)
        q0 = _clip(np.ceil(min(ay, by, cy)), nv)
        q1 = _clip(np.floor(max(ay, by, cy)) + 1, nv)
        for p in range(p0, p1):
            for q in range(q0, q1):
                wa = _orient(bx, by, cx, cy, p, q) * sa
                wb = _orient(cx, cy, ax, ay, p, q) * sb
                wc = _orient(ax, ay, bx, by, p, q) * sc
                if wa < 0 or wb < 0 or wc < 0:
                    continue
                if (wa == 0 and not ta) or (wb == 0 and not tb) or (wc == 0 and not tc):
                    continue
                ray = p * nv + q
                if fill:
                    hits[slot[ray]] = (wa * ws[i0] + wb * ws[i1] + wc * ws[i2]) / (wa + wb + wc)
                    signs[slot[ray]] = facing
                slot[ray] += 1


@njit(parallel=True)
def _vote(hits, signs, start, votes, bit, valid, winding):
    """Sort each ray's crossings; set ``bit`` in ``votes[p, q, k]`` where the ray is inside.

    By parity, inside is between pairs of crossings, and rays with an odd number of crossings
    are marked invalid and vote nothing. By ``winding``, inside is where the running sum of the
    crossings' ``signs`` is not zero, and rays whose sum does not come back to zero are invalid.
    """
    nu, nv, n = votes.shape
    for p in prange(nu):
        for q in range(nv):
            ray = p * nv + q
            a, b = start[ray], start[ray + 1]
            for i in range(a + 1, b):  # insertion sort: a ray meets few triangles
                t, s = hits[i], signs[i]
                j = i - 1
                while j >= a and hits[j] > t:
                    hits[j + 1] = hits[j]
                    signs[j + 1] = signs[j]
                    j -= 1
                hits[j + 1] = t
                signs[j + 1] = s
            if winding:
                total = 0
                for i in range(a, b):
                    total += signs[i]
                if total != 0:
                    valid[ray] = False
                    continue
                number = 0
                for i in range(a, b - 1):
                    number += signs[i]
                    if number != 0:
                        for k in range(_clip(np.floor(hits[i]) + 1, n), _clip(np.ceil(hits[i + 1]), n)):
                            votes[p, q, k] |= bit
                continue
            if (b - a) % 2:
                valid[ray] = False
                continue
            for i in range(a, b, 2):
                for k in range(_clip(np.floor(hits[i]) + 1, n), _clip(np.ceil(hits[i + 1]), n)):
                    votes[p, q, k] |= bit


@njit(parallel=True)
def _decide(votes, valid_x, valid_y, valid_z):
    """Replace the vote bits by the voxel states, in place."""
    nx, ny, nz = votes.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                bits = votes[i, j, k]
                n_valid = valid_x[j, k] + valid_y[i, k] + valid_z[i, j]
                n_in = (bits & 1) + ((bits >> 1) & 1) + (bits >> 2)
                if n_valid < 2 or 2 * n_in == n_valid:
                    votes[i, j, k] = _UNDECIDED
                elif n_valid == 3 and (n_in == 0 or n_in == 3):
                    votes[i, j, k] = _IN if n_in else _OUT
                else:
                    votes[i, j, k] = _WEAK_IN if 2 * n_in > n_valid else _WEAK_OUT


@njit(parallel=True)
def _stretch_score(states, hits, start, strides, undecided, score):
    """Add to the score of each undecided voxel the mean decision (+1 in, -1 out)
    of the decided voxels on its stretch of ray ``(p, q)`` between two crossings.

    ``undecided`` holds the voxels' sorted flat indices, found from the ray
    position through the element ``strides`` of ``states``.
    """
    nu, nv, n = states.shape
    for p in prange(nu):
        for q in range(nv):
            ray = p * nv + q
            a, b = start[ray], start[ray + 1]
            k = 0
            for s in range(a, b + 1):
                end = max(k, _clip(np.ceil(hits[s]), n)) if s < b else n
                n_in = n_out = 0
                for m in range(k, end):
                    state = states[p, q, m]
                    if state != _UNDECIDED:
                        n_in += state & 1
                        n_out += 1 - (state & 1)
                if 0 < n_in + n_out < end - k:
                    mean = (n_in - n_out) / (n_in + n_out)
                    for m in range(k, end):
                        if states[p, q, m] == _UNDECIDED:
                            flat = p * strides[0] + q * strides[1] + m * strides[2]
                            score[np.searchsorted(undecided, flat)] += mean
                k = end


@njit()
def _seal(states, weak):
    """Settle the ``weak`` voxels (sorted flat indices) to 0 or 1, in place.

    Weak-outside voxels joined by face steps through weak-outside voxels to
    a certain-outside voxel or to the grid's border are outside; the others
    enclose nothing but a cavity made by the votes next to a hole, and are
    filled.
    """
    nx, ny, nz = states.shape
    flat = states.reshape(-1)
    queue = np.empty(weak.size, dtype=np.int64)
    tail = 0
    for f in weak:
        if flat[f] != _WEAK_OUT:
            continue
        i, j, k = f // (ny * nz), f // nz % ny, f % nz
        for o in range(6):
            a, b, c = i + OFFSETS_6[o, 0], j + OFFSETS_6[o, 1], k + OFFSETS_6[o, 2]
            if not (0 <= a < nx and 0 <= b < ny and 0 <= c < nz) or states[a, b, c] == _OUT:
                flat[f] = _OUT
                queue[tail] = f
                tail += 1
                break
    head = 0
    while head < tail:
        f = queue[head]
        head += 1
        i, j, k = f // (ny * nz), f // nz % ny, f % nz
        for o in range(6):
            a, b, c = i + OFFSETS_6[o, 0], j + OFFSETS_6[o, 1], k + OFFSETS_6[o, 2]
            if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz and states[a, b, c] == _WEAK_OUT:
                states[a, b, c] = _OUT
                queue[tail] = (a * ny + b) * nz + c
                tail += 1
    for f in weak:
        flat[f] = _IN if flat[f] == _WEAK_OUT else flat[f] & 1
