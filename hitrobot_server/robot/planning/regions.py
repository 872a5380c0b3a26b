"""The connected regions of a costmap's free cells, labelled once per costmap, so a search
between two regions is refused at once instead of exploring the whole map (a failed A* on a
site map is a second of CPU; this is a lookup).

Cells are joined through their four sides: the planner steps diagonally only when both side
cells are free (no corner cutting), so its 8-connected moves join exactly these regions.
"""

from __future__ import annotations

import numpy as np


def label_regions(free: np.ndarray) -> np.ndarray:
    """``labels[row, col]``: 0 where ``free`` is False, else a region number (> 0) shared by
    every free cell reachable from it. Runs of free cells along a row are joined with the
    overlapping runs of the next row (union-find over runs, not cells)."""
    height, width = free.shape
    padded = np.zeros((height, width + 2), dtype=np.int8)
    padded[:, 1:-1] = free
    edges = np.diff(padded, axis=1)
    rows, starts = np.nonzero(edges == 1)
    _rows, ends = np.nonzero(edges == -1)  # one end per start, in the same order
    parent = list(range(len(rows)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    first = np.searchsorted(rows, np.arange(height + 1)).tolist()
    starts_l, ends_l = starts.tolist(), ends.tolist()
    for row in range(height - 1):
        i, i_end = first[row], first[row + 1]
        j, j_end = first[row + 1], first[row + 2]
        while i < i_end and j < j_end:
            if starts_l[i] < ends_l[j] and starts_l[j] < ends_l[i]:
                a, b = root(i), root(j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
            if ends_l[i] < ends_l[j]:
                i += 1
            else:
                j += 1
    region = np.array([root(i) + 1 for i in range(len(parent))], dtype=np.int32)
    delta = np.zeros((height, width + 1), dtype=np.int32)
    np.add.at(delta, (rows, starts), region)
    np.add.at(delta, (rows, ends), -region)
    return np.cumsum(delta[:, :width], axis=1, dtype=np.int32)


class Regions:
    """A costmap's region labels, computed on first use (most costmaps are never searched
    across regions) and then kept with it."""

    __slots__ = ("_labels",)

    def __init__(self) -> None:
        self._labels: np.ndarray | None = None

    def joined(self, lethal: np.ndarray, a: tuple[int, int], b: tuple[int, int]) -> bool:
        """Whether cells ``a`` and ``b`` (col, row) are in one region of the cells that are
        neither ``lethal`` nor on the border (the search never enters those)."""
        if self._labels is None:
            blocked = lethal.copy()
            blocked[0, :] = blocked[-1, :] = blocked[:, 0] = blocked[:, -1] = True
            self._labels = label_regions(~blocked)
        labels = self._labels
        return bool(labels[a[1], a[0]] == labels[b[1], b[0]] != 0)
