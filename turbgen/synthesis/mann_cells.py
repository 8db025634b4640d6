"""Cell-averaged Mann factors near the k1 axis, which replace the point factors of the stencil there.

On the axis Phi33 ~ 1 / k1^2, so with dk1 << dk2, dk3 the point rule puts far too much energy in the cells
(k1, 0, 0) (Mann 1998). turbgen.validation.mann_lattice uses its own rule on purpose: do not share the rules."""

from __future__ import annotations

import numpy as np

from turbgen.theory.eddy_lifetime import shear_lifetime_table
from turbgen.theory.lattice import cell_rule, gauss_panel
from turbgen.theory.mann_tensor import sheared_tensor
from turbgen.theory.params import MannParams
from turbgen.synthesis.box_shape import BoxShape
from turbgen.synthesis.square_root import principal_sqrt

CELL_RADIUS = 2
CELL_K1_FACTOR = 4.0  # (1, 2) and (3, 8) change the paper box's sigma^2 by < 0.4 % and < 0.1 %
_CELL_GAUSS = 4
_CELL_SLABS = 16  # slabs per tensor evaluation (~100 k nodes)


def _cell_rule(center: float, width: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """The synthesis's rule over a cell: graded by halves towards the k1 axis down to 2 ``scale``."""
    return cell_rule(center, width, _CELL_GAUSS, 2 * scale, 2.0, 30)


def _slab_nodes(box: BoxShape, k1c: float, js: np.ndarray, ls: np.ndarray, off_axis: dict):
    """Quadrature nodes (k1, k2, k3) [rad/m], weights and cell numbers (row-major over js x ls) of the cells of the
    slab at k1 = ``k1c``; ``off_axis[(2, j)]`` / ``[(3, l)]``: the rules of the cells j, l != 0 (the same on every slab)."""
    dk1, dk2, dk3 = box.dk()
    x1, w1 = gauss_panel(k1c - dk1 / 2, k1c + dk1 / 2, 2)
    scale = max(abs(k1c), dk1 / 4)
    rules2 = [off_axis[(2, j)] if j else _cell_rule(j * dk2, dk2, scale) for j in js]
    rules3 = [off_axis[(3, l)] if l else _cell_rule(l * dk3, dk3, scale) for l in ls]
    x2, w2 = np.concatenate([r[0] for r in rules2]), np.concatenate([r[1] for r in rules2])
    x3, w3 = np.concatenate([r[0] for r in rules3]), np.concatenate([r[1] for r in rules3])
    id2 = np.repeat(np.arange(len(js)), [len(r[0]) for r in rules2])
    id3 = np.repeat(np.arange(len(ls)), [len(r[0]) for r in rules3])
    shape = (len(x1), len(x2), len(x3))
    k1n, k2n, k3n = (np.broadcast_to(v, shape).ravel() for v in (x1[:, None, None], x2[None, :, None], x3))
    weight = (w1[:, None, None] * w2[None, :, None] * w3[None, None, :]).ravel()
    cell = np.broadcast_to(id2[None, :, None] * len(ls) + id3[None, None, :], shape).ravel()
    return k1n, k2n, k3n, weight, cell


def axis_cells(params: MannParams, box: BoxShape) -> tuple[np.ndarray, np.ndarray]:
    """(cell_index, cell_factor): principal square roots of Phi_bar = (1/dV) ∫_cell Phi dk near the k1 axis, from nodes
    of _CELL_SLABS slabs per call, summed per cell in node order (the same sums as slab by slab)."""
    dk1, dk2, dk3 = box.dk()
    r2 = min(CELL_RADIUS, (box.nyp - 1) // 2)
    r3 = min(CELL_RADIUS, (box.nzp - 1) // 2)
    n_slabs = min(box.nk1, int(CELL_K1_FACTOR * max(dk2, dk3) / dk1) + 1)
    table = shear_lifetime_table(params)
    js, ls = np.arange(-r2, r2 + 1), np.arange(-r3, r3 + 1)
    ncell = len(js) * len(ls)
    off_axis = {(2, j): _cell_rule(j * dk2, dk2, 0.0) for j in js if j} | {(3, l): _cell_rule(l * dk3, dk3, 0.0) for l in ls if l}
    k1 = box.k1()
    factor = []
    for first in range(0, n_slabs, _CELL_SLABS):
        slabs = range(first, min(first + _CELL_SLABS, n_slabs))
        nodes = [_slab_nodes(box, k1[i], js, ls, off_axis) for i in slabs]
        k1n, k2n, k3n, weight = (np.concatenate([n[a] for n in nodes]) for a in range(4))
        cell = np.concatenate([n[4] + m * ncell for m, n in enumerate(nodes)])
        beta = params.gamma * table.from_ksq(k1n * k1n + k2n * k2n + k3n * k3n, params.length_scale_m)
        phi = sheared_tensor(k1n, k2n, k3n, params, beta=beta) * weight
        size = len(slabs) * ncell
        cells = np.stack(  # ∫_cell Phi dk / 2 (E|n|^2 = 2), (3, 3, slabs x cells)
            [[np.bincount(cell, phi[a, b], minlength=size) for b in range(3)] for a in range(3)]
        ) / 2.0
        if first == 0:
            cells[:, :, r2 * len(ls) + r3] = 0.0  # the cell around k = 0: the box mean stays zero
        factor.append(principal_sqrt(np.moveaxis(cells, -1, 0))[0])
    index = np.array([(i, j % box.nyp, l % box.nzp) for i in range(n_slabs) for j in js for l in ls], dtype=np.int64)
    index = index.reshape(-1, 3)
    factor = np.concatenate(factor).astype(np.float32) if factor else np.zeros((0, 3, 3), np.float32)
    return index, factor
