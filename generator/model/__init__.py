"""The model and its derivation: which system (`system`), its bodies' kinematics (`bodies`)
as exact polynomials (`polynomial`), the Lagrange equations derived from them
(`derivation`), and parameters folded into them (`specialise`). Depends on nothing else of ipgen
but `errors` and `common`.
"""
