"""The A* searches of the geodesic importance (`skelfilter.core.importance.geodesic_importance`):
one bounded search per pair over the boundary layer's 26-graph, guided by the larger of two lower
bounds (the unobstructed grid's path length and the landmarks' triangle inequality,
`skelfilter.core.geodesic_landmarks`), a packed-key 4-ary heap, and the pairs a failed search
covers."""

import math

import numpy as np
from numba import prange

from skelfilter.core.heap import pop, push
from skelfilter.runtime.compiled import njit

# Step length by number of coordinates that change (0 to 3).
STEP = (0.0, 1.0, math.sqrt(2.0), math.sqrt(3.0))


@njit(inline="always")
def _grid_distance(coords, u, tx, ty, tz):
    """Shortest-path length from node u to the voxel (tx, ty, tz) in the unobstructed 26-connected grid."""
    dx = abs(coords[u, 0] - tx)
    dy = abs(coords[u, 1] - ty)
    dz = abs(coords[u, 2] - tz)
    hi = max(dx, dy, dz)
    lo = min(dx, dy, dz)
    mid = dx + dy + dz - hi - lo
    return np.float32(STEP[3] * lo + STEP[2] * (mid - lo) + (hi - mid))


# A heap entry is one uint64: the bits of f above those of the complement of g (both non-negative
# float32, whose bit patterns order like the numbers), so the smallest key has the smallest f and,
# among equal f, the largest g: on a voxel grid many nodes share f, and the deeper one is nearer the
# target. The ints compare in one instruction where the (f, g) pairs took two loads each.
_LOW = np.uint64(0xFFFFFFFF)
_HIGH = np.uint64(32)


# A search that finds no path under cap + margin(hops) proves every pair within `hops` edges of its
# ends at each side (g(s, s2) and g(t, t2) at most hops sqrt(3)) longer than cap, by the triangle
# inequality. Two hops make each failed search reach 2 sqrt(3) further, a ring around its ellipse
# that costs less against the ellipse the longer the cap, and cover more pairs. Nodes settled by the
# searches that run on noisy fandisk (one hop -> two): at 96 (cap 26) 5.12 M -> 5.47 M, at 128 (cap
# 32) 3.75 M -> 3.73 M, at 192 (cap 44) 14.81 M -> 13.82 M, at 256 (cap 56) 41.4 M -> 38.2 M (failed
# searches 15.5 M -> 12.3 M; three hops settle as many, four more). So two hops from a cap of 32.
_TWO_HOPS_CAP = 32.0


def hops_for(cap):
    """Edges around a failed search's ends within which it covers pairs, for the cap ``cap``."""
    return 2 if cap >= _TWO_HOPS_CAP else 1


@njit(inline="always")
def _margin(hops):
    return np.float32(2 * hops * math.sqrt(3.0) + 0.01)  # 0.01: float32 sums of ~100 steps err far less


# Queries in turn per thread: runs of _RUN neighbouring ones, so that the pairs a search covers come
# after it in the same thread.
_RUN = 256


@njit()
def _astar_chunk(indptr, indices, steps, coords, sources, targets, cap, hops, queries_of, first, stride,
                 rho, expanded, covered, landmarks, slack):
    """The runs of queries ``first, first + stride, ...`` in turn, sharing one set of scratch arrays."""
    n = len(indptr) - 1
    count = landmarks.shape[1]
    to_target = np.empty(count, dtype=np.float32)  # the target's distance from each landmark
    reach = np.float32(cap + _margin(hops))
    # Per node: the query's tag and the bits of g; g belongs to the current query only when the tag
    # is its own, so nothing is reset between queries. Non-negative float32 bits compare as int32.
    state = np.zeros((n, 2), dtype=np.int32)
    keys = np.empty(1024, dtype=np.uint64)
    items = np.empty(1024, dtype=np.int32)
    step = np.empty(4, dtype=np.float32)
    for k in range(4):
        step[k] = STEP[k]
    number = np.empty(1, dtype=np.float32)  # float32 <-> its bits
    bits = number.view(np.uint32)
    # Tags of the nodes near a failed search's target, and of those near its source.
    near = np.zeros(n, dtype=np.int32)
    seen = np.zeros(n, dtype=np.int32)
    ring = np.empty(1024, dtype=np.int32)
    tag = 0
    for r in range(first, (len(sources) + _RUN - 1) // _RUN, stride):
        for q in range(r * _RUN, min((r + 1) * _RUN, len(sources))):
            if covered[q]:
                rho[q] = cap
                expanded[q] = 0
                continue
            tag += 1
            s = sources[q]
            t = targets[q]
            tx, ty, tz = coords[t, 0], coords[t, 1], coords[t, 2]
            for k in range(count):
                to_target[k] = landmarks[t, k]
            state[s, 0] = tag
            state[s, 1] = 0
            number[0] = _grid_distance(coords, s, tx, ty, tz)
            keys[0] = (np.uint64(bits[0]) << _HIGH) | _LOW  # g = 0
            items[0] = s
            size = 1
            length = reach
            settled = 0
            while size > 0:
                key = keys[0]
                u = items[0]
                size = pop(keys, items, size)
                gu_bits = np.int32(_LOW - (key & _LOW))
                if gu_bits > state[u, 1]:  # lazy deletion: u was reached again by a shorter path
                    continue
                bits[0] = np.uint32(gu_bits)
                gu = number[0]
                settled += 1
                if u == t:
                    length = gu
                    break
                for e in range(indptr[u], indptr[u + 1]):
                    v = indices[e]
                    gv = np.float32(gu + step[steps[e]])
                    number[0] = gv
                    gv_bits = np.int32(bits[0])
                    if state[v, 0] == tag and gv_bits >= state[v, 1]:
                        continue
                    state[v, 0] = tag
                    state[v, 1] = gv_bits
                    hv = _grid_distance(coords, v, tx, ty, tz)
                    for k in range(count):
                        # |d(L, t) - d(L, v)| <= d(v, t); less the slack for the float32 rounding of
                        # each distance. inf (a landmark another component holds) gives nan: skipped.
                        bound = np.float32(abs(to_target[k] - landmarks[v, k]) - slack)
                        if bound > hv:
                            hv = bound
                    fv = np.float32(gv + hv)
                    if fv >= reach:  # never queued, so the search ends when no f below reach is left
                        continue
                    if size == len(keys):
                        keys = np.concatenate((keys, np.empty_like(keys)))
                        items = np.concatenate((items, np.empty_like(items)))
                    number[0] = fv
                    size = push(keys, items, size, (np.uint64(bits[0]) << _HIGH) | (_LOW - np.uint64(gv_bits)), v)
            rho[q] = min(length, cap)
            expanded[q] = settled
            if length >= reach:
                _cover(indptr, indices, sources, targets, queries_of, s, t, hops, near, seen, ring, 2 * tag, covered)
                _cover(indptr, indices, sources, targets, queries_of, t, s, hops, near, seen, ring, 2 * tag + 1,
                       covered)


@njit()
def _within_hops(indptr, indices, start, hops, seen, mark, ring):
    """The nodes at most ``hops`` edges from ``start`` (tagged ``mark`` in ``seen``); their count, in ``ring``."""
    ring[0] = start
    seen[start] = mark
    count = 1
    begin = 0
    for _ in range(hops):
        end = count
        for i in range(begin, end):
            u = ring[i]
            for e in range(indptr[u], indptr[u + 1]):
                v = indices[e]
                if seen[v] != mark and count < len(ring):
                    seen[v] = mark
                    ring[count] = v
                    count += 1
        begin = end
    return count


@njit()
def _cover(indptr, indices, sources, targets, queries_of, s, t, hops, near, seen, ring, tag, covered):
    """Mark the queries from a node near ``s`` to a node near ``t`` (``hops`` edges each) as covered."""
    _within_hops(indptr, indices, t, hops, near, tag, ring)
    count = _within_hops(indptr, indices, s, hops, seen, tag, ring)
    for i in range(count):
        s2 = ring[i]
        for q in range(queries_of[s2], queries_of[s2 + 1]):
            if near[targets[q]] == tag:
                covered[q] = True


@njit(parallel=True)
def astar(indptr, indices, steps, coords, sources, targets, cap, hops, queries_of, n_chunks, landmarks, slack):
    rho = np.empty(len(sources), dtype=np.float32)
    expanded = np.empty(len(sources), dtype=np.int32)
    covered = np.zeros(len(sources), dtype=np.bool_)
    # Strided runs: neighbouring (sorted) queries are spatially close, so each run keeps some
    # locality while the chunks get statistically equal work.
    for c in prange(n_chunks):
        _astar_chunk(indptr, indices, steps, coords, sources, targets, cap, hops, queries_of, c, n_chunks,
                     rho, expanded, covered, landmarks, slack)
    return rho, expanded
