r"""A connection sampled on a shape grid — from another tool (sysplotter), a model, or measurements —
as a :class:`~geogait.systems.System`.

The samples :math:`A(r)` on a rectilinear grid are interpolated by a tensor-product cubic spline
(scipy's :class:`~scipy.interpolate.RegularGridInterpolator`, ``method="cubic"``, its spline
coefficients from a direct sparse solve): twice continuously differentiable, exact at the grid
points, with its derivatives :math:`\partial A/\partial r_i` from the same spline. Shapes outside
the grid are an error, never extrapolated: give a grid that covers the joint limits.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .._validation import MAX_MAGNITUDE, GeogaitError, check_array, fail
from ._base import check_shapes

__all__ = ["GridSystem"]

_MIN_POINTS = 4  # per axis: a cubic spline needs four


class GridSystem:
    r"""A local connection sampled on a rectilinear shape grid, interpolated smoothly (module docstring).

    Parameters
    ----------
    axes : sequence of d array-like
        Grid coordinates of each joint (radians, or the shape's own units), strictly increasing,
        at least 4 points each.
    connection : array-like of shape (n_1, ..., n_d, 3, d)
        :math:`A` at every grid point, in geogait's sign (:math:`\xi = -A\dot r`, paper eq. 1).
    name : str

    Attributes
    ----------
    n_joints : int
    bounds : ndarray of shape (d, 2)
        Smallest and largest grid coordinate of each joint.

    Examples
    --------
    >>> import numpy as np
    >>> from geogait.systems import PurcellSwimmer
    >>> axis = np.linspace(-2.2, 2.2, 45)
    >>> grid = GridSystem.sample(PurcellSwimmer(3), [axis, axis])
    >>> shape = np.array([0.3, -0.5])
    >>> bool(np.abs(grid.connection(shape) - PurcellSwimmer(3).connection(shape)).max() < 1e-5)
    True
    """

    def __init__(self, axes, connection, *, name: str = "grid"):
        owner = "GridSystem"
        if isinstance(axes, np.ndarray) and axes.ndim == 1 or not hasattr(axes, "__len__") or len(axes) < 1:
            raise fail("axes", owner, "a sequence of d one-dimensional arrays (one per joint)", axes)
        checked = []
        for k, axis in enumerate(axes):
            axis = check_array(axis, f"axes[{k}]", owner, ndim=1, limit=MAX_MAGNITUDE)
            if axis.size < _MIN_POINTS or np.any(np.diff(axis) <= 0):
                raise fail(f"axes[{k}]", owner, f"strictly increasing with at least {_MIN_POINTS} points", axis)
            checked.append(axis)
        d = len(checked)
        values = check_array(connection, "connection", owner, limit=MAX_MAGNITUDE)
        expected = tuple(axis.size for axis in checked) + (3, d)
        if values.shape != expected:
            raise fail("connection", owner, f"an array of shape {expected} (grid points × 3 × d)",
                       f"shape {values.shape}")
        from scipy.interpolate import RegularGridInterpolator
        from scipy.sparse.linalg import spsolve

        self.name, self.n_joints = str(name), d
        self.axes = tuple(checked)
        self.bounds = np.array([[axis[0], axis[-1]] for axis in checked])
        digest = hashlib.sha256(values.tobytes())
        for axis in checked:
            digest.update(axis.tobytes())
        self._digest = digest.hexdigest()[:16]  # in the repr: the ceiling cache keys on it
        # a direct solve: scipy's default iterative one stops at a tolerance (errors ~1e-5 at the nodes)
        self._spline = RegularGridInterpolator(self.axes, values, method="cubic", solver=spsolve)

    def __repr__(self) -> str:
        sizes = "×".join(str(axis.size) for axis in self.axes)
        return f"GridSystem(name={self.name!r}, n_joints={self.n_joints}, grid={sizes}, sha256={self._digest})"

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def sample(cls, system, axes, *, name: str | None = None) -> GridSystem:
        """Sample another system's connection on the grid of ``axes`` (e.g. to export it, or to test
        what a grid of a given spacing keeps).

        Parameters
        ----------
        system : System
        axes : sequence of d array-like
        name : str, optional
            Default: ``"<system name> (grid)"``.
        """
        axes = [np.asarray(axis, dtype=float) for axis in axes]
        mesh = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
        return cls(axes, system.connection(mesh), name=name or f"{getattr(system, 'name', 'system')} (grid)")

    @classmethod
    def from_sysplotter(cls, path, *, name: str | None = None) -> GridSystem:
        r"""Load a connection computed by sysplotter (Hatton's MATLAB toolbox) from its ``.mat`` file.

        Reads the system struct ``s``: the ndgrid arrays ``s.grid.eval{1..d}`` and the connection
        field ``s.vecfield.eval.content.Avec{1..3, 1..d}``. sysplotter keeps :math:`-A` there (the body
        velocity per unit shape velocity; it evaluates :math:`A` as ``-interpn(..., Avec{i,j}, ...)``),
        so geogait negates it. MATLAB files saved with ``-v7.3`` (HDF5) cannot be read by scipy:
        re-save with ``save(file, 's', '-v7')``.

        Parameters
        ----------
        path : str or Path
            A ``sysf_*_calc.mat`` file (or any ``.mat`` file holding such a struct ``s``).
        name : str, optional
            Default: the file's stem.
        """
        from scipy.io import loadmat
        from scipy.io.matlab import MatReadError

        path = Path(path)
        owner = "GridSystem.from_sysplotter"
        if not path.is_file():
            raise GeogaitError(f"{owner}: no file at {path}.")
        try:
            data = loadmat(path, simplify_cells=True)
        except (MatReadError, ValueError, NotImplementedError, OSError, TypeError) as error:
            raise GeogaitError(f"{owner}: {path} is not a MATLAB file scipy can read ({error}); a file saved "
                               "with -v7.3 must be re-saved with save(file, 's', '-v7').") from None
        try:
            grids = data["s"]["grid"]["eval"]
            fields = data["s"]["vecfield"]["eval"]["content"]["Avec"]
        except (KeyError, TypeError, IndexError):
            raise GeogaitError(f"{owner}: {path} holds no sysplotter struct 's' with s.grid.eval and "
                               "s.vecfield.eval.content.Avec.") from None
        grids = _cells(grids, owner, path, "s.grid.eval")
        d = len(grids)
        layout = np.shape(fields)  # (sysplotter's Avec is a 3 × d cell: rows x, y, θ; a d × 3 one reads wrongly)
        if len(layout) == 2 and layout != (3, d):
            raise GeogaitError(f"{owner}: s.vecfield.eval.content.Avec in {path} is a {layout[0]} × {layout[1]} cell; "
                               f"expected 3 × {d} (rows x, y, θ; a column per joint).")
        fields = _cells(fields, owner, path, "s.vecfield.eval.content.Avec")
        if d < 2 or len(fields) != 3 * d:
            raise GeogaitError(f"{owner}: {path} has {d} grid arrays and {len(fields)} connection fields; "
                               f"expected d >= 2 ndgrid arrays and 3 × d fields.")
        axes = []
        for k, grid in enumerate(grids):
            if grid.ndim != d:
                raise GeogaitError(f"{owner}: s.grid.eval{{{k + 1}}} in {path} has {grid.ndim} dimensions, "
                                   f"expected {d} (one per joint).")
            axis = np.moveaxis(grid, k, 0).reshape(grid.shape[k], -1)
            if not np.allclose(axis, axis[:, :1]):
                raise GeogaitError(f"{owner}: s.grid.eval{{{k + 1}}} in {path} is not an ndgrid array "
                                   f"(it varies along another axis than {k + 1}).")
            axes.append(axis[:, 0])
        try:  # MATLAB stores the 3 × d cell column by column
            connection = -np.stack([np.stack([fields[row + 3 * col].reshape(grids[0].shape)
                                              for col in range(d)], axis=-1) for row in range(3)], axis=-2)
        except ValueError:
            raise GeogaitError(f"{owner}: the connection fields in {path} are not shaped like its grid "
                               f"{grids[0].shape}.") from None
        return cls(axes, connection, name=name or path.stem)

    # -- the connection -----------------------------------------------------------------------
    def connection(self, shapes) -> np.ndarray:
        """Interpolated connection ``(..., 3, d)`` at shapes ``(..., d)`` inside the grid.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
        """
        shapes = self._inside(shapes, f"{self.name}.connection")
        return self._spline(shapes.reshape(-1, self.n_joints)).reshape(shapes.shape[:-1] + (3, self.n_joints))

    def connection_derivative(self, shapes) -> np.ndarray:
        r"""Derivatives :math:`\partial A_{kj}/\partial r_i` of the interpolated connection, ``(..., 3, d, d)``
        indexed ``[..., k, j, i]``.

        Parameters
        ----------
        shapes : array-like of shape (..., d)
            Inside the grid.
        """
        shapes = self._inside(shapes, f"{self.name}.connection_derivative")
        flat = shapes.reshape(-1, self.n_joints)
        parts = [self._spline(flat, nu=tuple(int(i == j) for j in range(self.n_joints)))
                 for i in range(self.n_joints)]
        return np.stack(parts, axis=-1).reshape(shapes.shape[:-1] + (3, self.n_joints, self.n_joints))

    def _inside(self, shapes, owner: str) -> np.ndarray:
        shapes = check_shapes(shapes, self.n_joints, owner)
        low, high = self.bounds[:, 0], self.bounds[:, 1]
        outside = (shapes < low) | (shapes > high)
        if np.any(outside):
            joint = int(np.argwhere(outside)[0][-1])
            value = float(shapes[..., joint][outside[..., joint]].flat[0])
            raise GeogaitError(f"The 'shapes' argument of {owner} must lie inside the sampled grid; joint {joint} "
                               f"is {value:.6g}, outside [{low[joint]:.6g}, {high[joint]:.6g}] (extend the grid "
                               "to cover the joint limits and the exploration).")
        return shapes


def _cells(value, owner: str, path, field: str) -> list:
    """A MATLAB cell array read by scipy (an object array) as a flat list of float arrays, column-major; each
    cell real, finite and within ±1e12 (scipy reads complex and logical arrays as they are)."""
    if not (isinstance(value, np.ndarray) and value.dtype == object):
        raise GeogaitError(f"{owner}: {field} in {path} is not a cell array of grids.")
    return [check_array(cell, f"{field}{{{k + 1}}} in {path}", owner, limit=MAX_MAGNITUDE)
            for k, cell in enumerate(value.ravel(order="F"))]
