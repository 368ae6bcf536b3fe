"""`polynomial.sparse` (what code generation reads) against FLINT's own exponent vectors.

`sparse` reads a small ring's polynomials from their exponent vectors (`terms`) and a large
ring's from FLINT's text (python-flint's `str` leaks memory, but is ten times faster at 20
links); these tests check both readings term by term against `fmpq_mpoly.to_dict()` (dense
exponent vectors, exact coefficients), on random polynomials over a real system's generators
(names like `delta0`, `c1_2`, `rho1`).
"""

from __future__ import annotations

from fractions import Fraction
from math import gcd

from flint import fmpq
from hypothesis import given, settings
from hypothesis import strategies as st

from ipgen.model import polynomial
from ipgen.model.bodies import algebra_for
from ipgen.model.polynomial import Poly, sparse
from ipgen.model.system import System

ALGEBRA = algebra_for(System("rotary", 3))
N_GENERATORS = len(ALGEBRA.gens)

monomials = st.dictionaries(st.integers(0, N_GENERATORS - 1), st.integers(1, 4), max_size=5)
coefficients = st.fractions(max_denominator=10**12).filter(lambda c: c != 0) | st.sampled_from(
    [Fraction(1), Fraction(-1), Fraction(10**40 + 1, 3), Fraction(-7, 10**30)]
)
polynomials = st.lists(st.tuples(monomials, coefficients), max_size=12)


def _build(terms: list[tuple[dict[int, int], Fraction]]) -> Poly:
    p = ALGEBRA.zero
    for powers, c in terms:
        exponents = [0] * N_GENERATORS
        for g, e in powers.items():
            exponents[g] = e
        p += ALGEBRA.ring.term(coeff=fmpq(c.numerator, c.denominator), exp_vec=tuple(exponents))
    return p


def _expected(p: Poly) -> dict[tuple[int, ...], Fraction]:
    result = {}
    for exponents, c in p.to_dict().items():
        monomial = tuple(g for g, e in enumerate(exponents) for _ in range(e))
        result[monomial] = Fraction(int(c.p), int(c.q))
    return result


@settings(max_examples=300, deadline=None)
@given(polynomials)
def test_sparse_matches_flint_exponent_vectors(terms: list[tuple[dict[int, int], Fraction]]) -> None:
    p = _build(terms)
    readings = [sparse(p)]
    if not p.is_zero():
        readings += [polynomial._from_terms(p), polynomial._from_text(p)]
    for numerators, den in readings:
        assert {m: Fraction(n, den) for m, n in numerators.items()} == _expected(p)
        assert all(list(m) == sorted(m) for m in numerators)
        # lowest terms: no common factor of the denominator and all numerators
        assert gcd(den, *numerators.values()) == 1


def test_sparse_examples() -> None:
    m1, l1, s1, c1_2 = (ALGEBRA.index(name) for name in ("m1", "l1", "s1", "c1_2"))
    gens = ALGEBRA.gens
    p = gens[m1] * gens[l1] ** 2 * gens[s1] * fmpq(-3, 2) + gens[c1_2] / 3 - 5
    assert sparse(p) == ({(m1, l1, l1, s1): -9, (c1_2,): 2, (): -30}, 6)
    assert sparse(ALGEBRA.zero) == ({}, 1)
    assert sparse(ALGEBRA.constant(Fraction(-1, 4))) == ({(): -1}, 4)


def test_a_small_ring_is_read_without_flints_text(monkeypatch) -> None:
    """python-flint 0.9.0's `fmpq_mpoly.str` leaks about 4 kB a call: a process generating
    headers grew by 40 kB a header (a resource audit). A ring of up to TERMS_UP_TO generators
    (a rotary chain to 5 links) never asks for the text; a larger one does (speed)."""
    import tempfile
    from pathlib import Path

    from ipgen.pipeline.generate import generate

    def refused(p: Poly) -> None:
        raise AssertionError("read from FLINT's text")

    assert algebra_for(System("rotary", 5)).ring.nvars() <= polynomial.TERMS_UP_TO
    monkeypatch.setattr(polynomial, "_from_text", refused)
    with tempfile.TemporaryDirectory() as folder:
        generate(System("rotary", 2), "m", Path(folder), emit=("cpp", "c", "library"))
    large = algebra_for(System("classical", 20))
    assert large.ring.nvars() > polynomial.TERMS_UP_TO
    try:
        sparse(large.gens[0] + 1)
    except AssertionError as error:
        assert "FLINT's text" in str(error)
    else:
        raise AssertionError("a large ring read without the text")
