"""The partitioned workspace and its guiding nodes (paper, "Guided path planning module").

Preprocessing splits the box the wrist can reach into ``Settings.grid_cells`` cells along
each axis (11 in the paper). The box is axis-aligned in the canonical arm frame and holds
every wrist position at any chest rotation: ``|xy| ≤ |shoulder_xy| + L`` and
``|z - shoulder_z| ≤ L``.

A cell is **occupied** when an obstacle surface comes within its circumscribed sphere (one
bounded BVH query per cell, conservative) or when it lies inside a closed obstacle. Free
cells that do not touch a surface form connected regions that a surface cannot cross
without occupying a cell between them (two 26-neighbours' centres are at most two
half-diagonals apart), so one inside/outside test per region settles all of its cells.

A free cell is a **valid guiding node** when the wrist can be at its centre with at least
one legal, collision-free pose (the configuration generator, without a previous pose).
Guiding nodes for a reach are the centres along the shortest path (Dijkstra, Euclidean
edge lengths, 26-connected) through valid cells from the cell nearest the start to the
cell nearest the target.
"""

from __future__ import annotations

import heapq
import itertools
import time
from dataclasses import dataclass

import numpy as np

from . import ik
from .body_capsules import body_capsules_at, segment_hits_body, self_collision
from .generator import ConfigurationGenerator
from .steps import drain

_NEIGHBOURS = np.array([d for d in itertools.product((-1, 0, 1), repeat=3) if any(d)])


@dataclass
class Workspace:
    """The grid: canonical-frame box, per-cell occupancy and validity."""

    lower: np.ndarray       # (3,) corner of the box
    cell: np.ndarray        # (3,) cell size along each axis
    n: int
    occupied: np.ndarray    # (n, n, n) bool
    valid: np.ndarray       # (n, n, n) bool: valid guiding nodes
    build_time_s: float

    def center(self, index) -> np.ndarray:
        return self.lower + (np.asarray(index, dtype=float) + 0.5) * self.cell

    def centers(self) -> np.ndarray:
        """All cell centres, (n, n, n, 3)."""
        idx = np.stack(np.meshgrid(*(np.arange(self.n),) * 3, indexing="ij"), -1)
        return self.center(idx)

    def valid_centers(self) -> np.ndarray:
        return self.centers()[self.valid]

    def nearest_valid(self, point):
        """Index of the valid cell whose centre is nearest ``point`` (ties: lowest index),
        or None if no cell is valid."""
        cells = np.argwhere(self.valid)
        if len(cells) == 0:
            return None
        d = np.linalg.norm(self.center(cells) - np.asarray(point), axis=-1)
        return tuple(int(v) for v in cells[int(np.argmin(d))])

    def shortest_path(self, start, goal):
        """Cell indices of the shortest path through valid cells (26-connected, Euclidean
        edge lengths, Dijkstra), or None if the cells are not connected."""
        start, goal = tuple(start), tuple(goal)
        n = self.n
        dist = {start: 0.0}
        parent = {}
        heap = [(0.0, start)]
        steps = [(tuple(d), float(np.linalg.norm(d * self.cell))) for d in _NEIGHBOURS]
        while heap:
            d, cur = heapq.heappop(heap)
            if cur == goal:
                path = [cur]
                while cur in parent:
                    cur = parent[cur]
                    path.append(cur)
                return path[::-1]
            if d > dist.get(cur, np.inf):
                continue
            for (dx, dy, dz), w in steps:
                nxt = (cur[0] + dx, cur[1] + dy, cur[2] + dz)
                if not (0 <= nxt[0] < n and 0 <= nxt[1] < n and 0 <= nxt[2] < n):
                    continue
                if not self.valid[nxt]:
                    continue
                nd = d + w
                if nd < dist.get(nxt, np.inf) - 1e-12:
                    dist[nxt] = nd
                    parent[nxt] = cur
                    heapq.heappush(heap, (nd, nxt))
        return None

    def guiding_nodes(self, start_point, goal_point) -> np.ndarray:
        """Guiding node positions (k, 3) leading from ``start_point`` toward ``goal_point``:
        the centres of the shortest valid-cell path, without its first cell (where the
        wrist already is) and its last (the target itself follows). Empty if start and goal
        share a cell or are not connected."""
        a = self.nearest_valid(start_point)
        b = self.nearest_valid(goal_point)
        if a is None or b is None or a == b:
            return np.zeros((0, 3))
        path = self.shortest_path(a, b)
        if path is None or len(path) <= 2:
            return np.zeros((0, 3))
        return self.center(np.array(path[1:-1]))


def workspace_box(arm, settings):
    """(lower corner, cell size) of the grid in the canonical frame."""
    length = arm.arm_length
    radius = float(np.hypot(arm.shoulder[0], arm.shoulder[1])) + length
    lower = np.array([-radius, -radius, arm.shoulder[2] - length])
    upper = np.array([radius, radius, arm.shoulder[2] + length])
    return lower, (upper - lower) / settings.grid_cells


def build_workspace(generator: ConfigurationGenerator) -> Workspace:
    """Preprocess the workspace for one arm and one obstacle set, in one go
    (:func:`workspace_steps` run to the end)."""
    return drain(workspace_steps(generator, None))


def workspace_steps(generator: ConfigurationGenerator, chunk: int | None = 8):
    """Preprocess the workspace (see the module doc) as a generator: it yields between
    slices of work and returns the :class:`Workspace`, so live mode can build it within
    its time budget. Arm poses are tested ``chunk`` cells at a time (None: all at once);
    the grid does not depend on the chunk. ``build_time_s`` counts the time spent
    building, not the time between slices."""
    busy = 0.0
    t = time.perf_counter()
    arm, obstacles, settings = generator.arm, generator.obstacles, generator.settings
    n = settings.grid_cells
    lower, cell = workspace_box(arm, settings)
    idx = np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), -1).reshape(-1, 3)
    centers = lower + (idx + 0.5) * cell
    world = arm.to_world_points(centers)
    half_diagonal = 0.5 * float(np.linalg.norm(cell))
    occupied = np.zeros(n ** 3, dtype=bool)
    if not obstacles.empty:
        tree = obstacles.tree
        bound = half_diagonal + generator.checker.margin
        for k, p in enumerate(world.tolist()):
            occupied[k] = tree.find_nearest(p, bound)[0] is not None
        occupied = occupied.reshape(n, n, n)
        busy += time.perf_counter() - t
        yield
        t = time.perf_counter()
        labels = _free_regions(occupied)
        for k, first in enumerate(np.unique(labels[labels >= 0]).tolist()):
            if obstacles.point_inside(world[first]):
                occupied |= labels == first
            if k % 8 == 7:
                busy += time.perf_counter() - t
                yield
                t = time.perf_counter()
    else:
        occupied = occupied.reshape(n, n, n)
    busy += time.perf_counter() - t
    yield
    t = time.perf_counter()

    valid = np.zeros((n, n, n), dtype=bool)
    free = np.flatnonzero(~occupied.reshape(-1) & _within_reach(arm, settings, centers))
    # Batches of at least two wrists: ik.solve scores one wrist with float arithmetic and
    # several with arrays; the grid must not depend on where the slices fall.
    bounds = list(range(0, free.size, chunk or max(free.size, 1)))
    if len(bounds) > 1 and free.size - bounds[-1] < 2:
        bounds.pop()
    for b, lo in enumerate(bounds):
        hi = bounds[b + 1] if b + 1 < len(bounds) else free.size
        rows = free[lo:hi]
        sol = ik.solve(arm, centers[rows], settings) if rows.size > 1 else \
            ik.solve(arm, centers[np.repeat(rows, 2)], settings)
        for row in np.flatnonzero(sol.valid[: rows.size].any(1)).tolist():
            flat = rows[row]
            order = sol.order(row, settings.elbow_side)[: settings.max_pose_tries]
            valid.reshape(-1)[flat] = _any_clear(generator, sol, row, order)
        busy += time.perf_counter() - t
        yield
        t = time.perf_counter()
    busy += time.perf_counter() - t
    return Workspace(lower, cell, n, occupied, valid, busy)


def _within_reach(arm, settings, centers) -> np.ndarray:
    """(N,) False where no chest rotation brings the shoulder within the arm's reach of a
    wrist at ``centers`` (canonical): the shoulder turns about the z axis on a circle, and
    the wrist's distance to it lies between its distances to the circle's nearest and
    farthest points, which must straddle [shortest reach, L] for :func:`ik.solve` to call
    it reachable. A prefilter only (with a little slack): it saves solving cells that can
    never be valid, and leaves the grid as it is."""
    rho = float(np.hypot(arm.shoulder[0], arm.shoulder[1]))
    r = np.hypot(centers[:, 0], centers[:, 1])
    dz = centers[:, 2] - float(arm.shoulder[2])
    slack = 1e-6 * arm.arm_length
    near, far = np.hypot(r - rho, dz), np.hypot(r + rho, dz)
    shortest = arm.min_reach(settings.elbow_max)
    return (near <= arm.upper_arm_length + arm.forearm_length + slack) & (far >= shortest - slack)


def _any_clear(generator: ConfigurationGenerator, sol, row: int, order) -> bool:
    """Does one of wrist ``row``'s candidates ``order`` (best first) of ``sol`` clear the
    body and the obstacles (arm only)? Tested one at a time, best first, and stopped at
    the first clear one: the answer is the same as testing all of them, and the best
    candidate usually settles it, so the rest are not even built. A wrist inside the body
    (closer to a body capsule than the forearm's radius) settles it at once: every forearm
    ends there."""
    arm = generator.arm
    body = float(sol.body[row])
    capsules = body_capsules_at(arm, body)
    wrist = sol.wrists[row].tolist()
    if segment_hits_body(wrist, wrist, arm.forearm_radius, capsules):
        return False

    def candidates():
        yield from sol.joints(row, order[:1])
        if order.size > 1:
            yield from sol.joints(row, order[1:])

    for pose in candidates():
        if not self_collision(arm, body, pose[None], include_hand=False,
                                 capsules=capsules)[0] and \
                not generator.checker.collides(arm.to_world_points(pose), include_hand=False):
            return True
    return False


def _free_regions(occupied) -> np.ndarray:
    """The 26-connected regions of cells clear of any surface, as labels (n, n, n): each
    free cell holds the row-major index of its region's first cell (the cell tested for
    being inside an obstacle), occupied cells -1. Labels are spread by taking the least
    label among the 26 neighbours and then each label's own label (pointer jumping), until
    nothing changes: a few array passes instead of a flood fill cell by cell."""
    n = occupied.shape[0]
    free = ~occupied
    none = occupied.size
    labels = np.where(free, np.arange(occupied.size).reshape(occupied.shape), none)
    shifts = [tuple(slice(1 + d, 1 + d + n) for d in step) for step in _NEIGHBOURS.tolist()]
    while True:
        padded = np.pad(labels, 1, constant_values=none)
        least = labels.copy()
        for window in shifts:
            np.minimum(least, padded[window], out=least)
        least[occupied] = none
        flat = least.reshape(-1)
        jumped = flat.copy()
        jumped[free.reshape(-1)] = np.append(flat, none)[flat[free.reshape(-1)]]
        jumped = jumped.reshape(least.shape)
        if np.array_equal(jumped, labels):
            return np.where(free, labels, -1)
        labels = jumped
