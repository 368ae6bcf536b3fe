"""Code generation: sympy expressions → C++ statements → a rendered header."""
