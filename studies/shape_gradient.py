"""Study behind issue 10's model choice on 9 links: where the shape-space model's gradient error comes from.

Fits a model offline to ``CYCLES`` simulated cycles of the 9-link seed gait (perturbation 0.15 rad, sensor
noise ``--noise``), then compares its predicted objective's gradient in the symmetric gait family at the
seed with the true one (the perfect-information model). ``--model rls`` is ``ShapeSpaceModel(degree=D,
symmetry="mirror+reversal", forgetting_factor=1)``; with it, each learned row of A(r) is also put alone into
the true connection, which shows which row the error comes from. ``--model lstsq`` solves the same
symmetric least-squares problem directly (ridge ``--ridge``). ``--shrinkage b`` multiplies the ridge of
degree-q weights by b^q (the model's ``degree_shrinkage``: prior variance δ₀ b^-q, δ₀ = 100).

    python studies/shape_gradient.py CYCLES [--degree 3] [--noise 0.0] [--model rls|lstsq] [--ridge 0.01]
                                     [--shrinkage 1]
"""

import argparse

import numpy as np

from geogait.gaits import Perturbation, SymmetricGaitFamily, seed_gait
from geogait.models import PerfectInformationModel, ShapeSpaceModel, monomial_exponents, monomials, symmetry_blocks
from geogait.optimize._steps import StepProblem
from geogait.simulate import simulate
from geogait.systems import FunctionSystem, PurcellSwimmer

SWIMMER = PurcellSwimmer(9)


def gradient(connection, family, params):
    """Value and gradient of the predicted objective at ``params`` under ``connection``."""
    system = FunctionSystem(connection, n_joints=SWIMMER.n_joints)
    value, slope, *_ = StepProblem(PerfectInformationModel(system=system).predict_displacement, family).evaluate(params)
    return value, slope


def least_squares(run, degree, ridge, shrinkage):
    """Connection of the symmetric polynomial model solved in one go (ridge ``ridge`` b^q on degree q)."""
    exponents = monomial_exponents(SWIMMER.n_joints, degree)
    features = monomials(run.shape, exponents)[:, :, None] * run.shape_velocity[:, None, :]
    features = features.reshape(len(run.shape), -1)
    penalty = ridge * shrinkage ** np.repeat(exponents.sum(axis=1), SWIMMER.n_joints)
    weights = np.zeros((features.shape[1], 3))
    for outputs, basis in symmetry_blocks(exponents, "mirror+reversal"):
        z = features @ basis
        weights[:, outputs] = basis @ np.linalg.solve(z.T @ z + basis.T @ (penalty[:, None] * basis),
                                                      z.T @ run.body_velocity[:, outputs])
    weights = weights.reshape(len(exponents), SWIMMER.n_joints, 3)
    return lambda shape: -np.einsum("...l,ljk->...kj", monomials(shape, exponents), weights)


def main(cycles, degree, noise, model, ridge, shrinkage=1.0):
    seed = seed_gait(SWIMMER.n_joints)
    family = SymmetricGaitFamily.from_gait(seed)
    params = family.params_of(seed)
    run = simulate(SWIMMER, seed, n_cycles=cycles, perturbation=Perturbation.from_std(0.15), sensor_noise=noise, seed=3)
    true_value, true_slope = gradient(SWIMMER.connection, family, params)
    if model == "lstsq":
        learned = least_squares(run, degree, ridge, shrinkage)
    else:
        fitted = ShapeSpaceModel(degree=degree, symmetry="mirror+reversal", forgetting_factor=1.0,
                                 degree_shrinkage=shrinkage)
        learned = fitted.fit(run.phase, run.shape, run.shape_velocity, run.body_velocity).connection
    rows = {"all rows": [0, 1, 2]} if model == "lstsq" else {"x row": [0], "y row": [1], "θ row": [2],
                                                              "all rows": [0, 1, 2]}
    solver = (f"lstsq, ridge {ridge:g}" if model == "lstsq" else "rls") + f", shrinkage {shrinkage:g}"
    print(f"9-link, degree {degree}, {solver}, {cycles} cycles, noise {noise}: true objective {true_value:.4f}, "
          f"|true gradient| {np.linalg.norm(true_slope):.4f}")
    for name, which in rows.items():
        def hybrid(shape, which=which):
            connection = SWIMMER.connection(shape)
            connection[..., which, :] = learned(shape)[..., which, :]
            return connection

        value, slope = gradient(hybrid, family, params)
        cosine = slope @ true_slope / np.linalg.norm(slope) / np.linalg.norm(true_slope)
        print(f"  learned {name:8s}: objective {value:.4f}, gradient error {np.linalg.norm(slope - true_slope):.4f}, "
              f"cosine {cosine:.3f}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cycles", type=int)
    parser.add_argument("--degree", type=int, default=3)
    parser.add_argument("--noise", type=float, default=0.0)
    parser.add_argument("--model", choices=("rls", "lstsq"), default="rls")
    parser.add_argument("--ridge", type=float, default=0.01)
    parser.add_argument("--shrinkage", type=float, default=1.0)
    arguments = parser.parse_args()
    main(arguments.cycles, arguments.degree, arguments.noise, arguments.model, arguments.ridge, arguments.shrinkage)
