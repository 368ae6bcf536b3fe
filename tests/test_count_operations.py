"""The operation count every header states (`Cost:`) and the benches compare: what counts."""

from __future__ import annotations

import pytest

from ipgen.codegen.functions import count_operations

CASES = [
    ("const Scalar h1 = m1*com1;", 1),
    ("b(1) = delta1*dq1 + t3*t5 - t6 - t2*g;", 6),
    ("b(2) = -t6 - t1*t5;", 3),  # a leading negation counts
    ("M(1, 0) = c1*a1;", 1),  # the target's indices are not operations
    ("M[1*3 + 0] = c1*a1;", 1),  # nor a C array's flat index
    ("const Scalar t6 = delta2*(dq2 - dq1);", 2),
    ("const Scalar t0 = Scalar(1)/Scalar(12)*m1*l1*l1;", 3),  # a literal ratio is a constant
    ("const IPGEN_SCALAR t0 = (IPGEN_SCALAR)1/(IPGEN_SCALAR)3*m1;", 1),
    ("const IPGEN_SCALAR t1 = (IPGEN_SCALAR)2*dq0;", 1),
    ("const Scalar s1 = sin(q(1));", 0),
    ("const IPGEN_SCALAR c2 = ipgen_cos(q[2]);", 0),
    ("const Scalar s1_2 = s1*c2 - c1*s2;  // sin(θ1 − θ2)", 3),  # comments are not code
    # a conditional: the condition and its costlier branch
    ("const Scalar com1 = detail::given(p.com[1]) ? p.com[1] : Scalar(1)/Scalar(2)*l1;", 1),
    ("const IPGEN_SCALAR J1 = links ? links->J[1] : (IPGEN_SCALAR)1/(IPGEN_SCALAR)12*m1*l1*l1;", 3),
    ("D = Scalar(1)/Scalar(2)*(delta0*dq0*dq0 + t0*t0*delta2);", 6),
    ("b(0) -= u;", 0),  # only the right-hand side counts (the solve and the input are apart)
    ("return b;", 0),
]


@pytest.mark.parametrize(("statement", "operations"), CASES)
def test_count_operations(statement: str, operations: int) -> None:
    assert count_operations(statement) == operations
