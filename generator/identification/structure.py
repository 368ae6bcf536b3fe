"""What the equations' structure alone says about identifiability (no data needed).

The residual is Σ_k φ_k(p) Y_k with monomials φ_k = Π_j p_j^(e_kj) (model.py). Scaling the free
parameters as p_j → p_j · exp(s v_j) leaves every monomial unchanged exactly when E v = 0 (E the
integer exponent matrix): then no data, however rich, can tell those parameters apart — they
enter only through the monomials restricted to v's support, e.g. "m1 and com1 enter only as
m1·com1". `structural_statements` lists a basis of E's (rational) null space in those words, and
the monomials whose regressor columns are proportional whatever the data (model.py, `shared`:
delta0 and kt·km both multiply θ̇0), which the data can only see as a sum.
"""

from __future__ import annotations

from ipgen.identification.model import Monomial, StructuralModel

__all__ = ["structural_statements", "symmetries"]


def symmetries(model: StructuralModel) -> list[list[int]]:
    """Integer basis vectors v of {v : E v = 0} (each over the free parameters)."""
    import math

    import sympy as sp

    rows = model.exponents()
    if not rows:
        return [[1] * len(model.free)] if model.free else []
    basis = sp.Matrix(rows).nullspace()
    out = []
    for vector in basis:
        denominators = [sp.fraction(x)[1] for x in vector]
        factor = math.lcm(*(int(d) for d in denominators))
        ints = [int(x * factor) for x in vector]
        common = math.gcd(*ints) or 1
        out.append([v // common for v in ints])
    return out


def structural_statements(model: StructuralModel) -> list[str]:
    """One sentence per structural symmetry (module docstring); [] when there is none."""
    statements = []
    for vector in symmetries(model):
        support = [name for name, v in zip(model.free, vector, strict=True) if v]
        combinations = []
        for monomial in model.monomials:
            restricted = tuple((n, p) for n, p in monomial.powers if n in support)
            if restricted:
                text = Monomial(restricted).text()
                if text not in combinations:
                    combinations.append(text)
        names = " and ".join([", ".join(support[:-1]), support[-1]]) if len(support) > 1 else support[0]
        if combinations:
            through = ", ".join(combinations)
            statements.append(
                f"{names} enter only as {through} here: the data cannot separate them (fix one of them)"
            )
        else:
            statements.append(f"{names} do not enter these equations: they cannot be identified")
    for group in model.shared:
        if not _group_loses_rank(model, group):
            continue  # e.g. J1 and m1·com1² share a column, but m1·com1 alone fixes com1
        texts = [model.monomials[k].text() for k in group]
        statements.append(
            f"{' and '.join([', '.join(texts[:-1]), texts[-1]])} multiply the same term of the equations "
            "(they enter only as a weighted sum): the data cannot separate them (fix all but one)"
        )
    return statements


def _group_loses_rank(model: StructuralModel, group: tuple[int, ...]) -> bool:
    """Whether seeing only a weighted sum of the monomials in `group` (rather than each) leaves a
    direction of the free parameters unseen: the rank of the monomials' gradients at a generic
    point drops when the group's rows are summed (random weights and point: generic rank)."""
    import numpy as np

    rng = np.random.default_rng(7)
    p = rng.uniform(0.5, 1.5, len(model.free))
    exponents = np.array(model.exponents(), dtype=float).reshape(len(model.monomials), len(model.free))
    phi = np.prod(p[None, :] ** exponents, axis=1)
    gradients = exponents * phi[:, None] / p[None, :]
    weights = rng.uniform(0.5, 1.5, len(group))
    summed = weights @ gradients[list(group)]
    others = np.delete(gradients, list(group), axis=0)
    seen = np.vstack([others, summed[None, :]])
    return int(np.linalg.matrix_rank(seen)) < int(np.linalg.matrix_rank(gradients))
