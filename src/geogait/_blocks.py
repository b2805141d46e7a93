"""Work over a long log in blocks of rows, so that SIGTERM and Ctrl-C are handled between them (module).

Python handles a signal between bytecodes, never inside a compiled call. One NumPy or LAPACK call over every row
of a million-row log takes a second or more on a loaded machine, and a signal waits for it. Above
:data:`BLOCK_ROWS` rows, the fits and predictions over a log's rows go block by block. Below it they run as one
call, so short logs give the same bits as they always did.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

__all__ = ["BLOCK_ROWS", "block_lstsq", "row_blocks"]

#: Rows per block. The longest compiled call over a block of this many rows takes well under
#: :data:`~geogait._validation.MAX_SOLVE_SECONDS` (the window model's rounds and a Fourier basis of order 16).
BLOCK_ROWS = 1 << 15


def row_blocks(n_rows: int, size: int | None = None) -> Iterator[slice]:
    """Slices of ``range(n_rows)``, in order, of ``size`` rows (default :data:`BLOCK_ROWS`; the last may be
    shorter); one slice when ``n_rows <= size``."""
    size = BLOCK_ROWS if size is None else size
    for start in range(0, max(n_rows, 1), size):
        yield slice(start, min(start + size, n_rows))


def block_lstsq(design: Callable[[slice], np.ndarray], targets: np.ndarray, size: int | None = None) \
        -> tuple[np.ndarray, np.ndarray]:
    """Least squares ``design(rows) @ x ≈ targets[rows]`` over every row, the design made a block at a time.

    Up to ``size`` rows: one :func:`numpy.linalg.lstsq`. Beyond, a tall-skinny QR: the triangular factor of
    ``[R, Qᵀy]`` stacked on the next block's ``[B, y]`` is that of every row so far, so the solve at the end is the
    least-squares solution of all the rows (to rounding; a rank-deficient design gets the minimum-norm one).

    Parameters
    ----------
    design : callable
        ``design(rows)`` for a slice ``rows``: the design matrix of those rows, ``(len, p)``.
    targets : ndarray of shape (n,) or (n, k)
    size : int, optional
        Rows per block (default :data:`BLOCK_ROWS`).

    Returns
    -------
    solution : ndarray of shape (p,) or (p, k)
    singular_values : ndarray of shape (p,)
        Of the whole design (its rank: those above ``max * max(n, p) * eps``).
    """
    targets = np.asarray(targets, dtype=float)
    n, size = targets.shape[0], BLOCK_ROWS if size is None else size
    if n <= size:
        solution, _, _, singular = np.linalg.lstsq(design(slice(0, n)), targets, rcond=None)
        return solution, singular
    column = targets.ndim == 1
    y = targets[:, None] if column else targets
    reduced = None
    for rows in row_blocks(n, size):
        block = np.hstack([design(rows), y[rows]])
        reduced = np.linalg.qr(block if reduced is None else np.vstack([reduced, block]), mode="r")
    p = reduced.shape[1] - y.shape[1]
    factor = reduced[:p, :p]
    solution, *_ = np.linalg.lstsq(factor, reduced[:p, p:], rcond=None)
    return (solution[:, 0] if column else solution), np.linalg.svd(factor, compute_uv=False)
