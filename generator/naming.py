"""C++ naming rules for model names: they become a namespace `ipgen::<name>` and `<name>.hpp`."""

from __future__ import annotations

import re

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
# C++20 keywords and alternative tokens, plus identifiers with special meaning in context.
CPP_KEYWORDS: frozenset[str] = frozenset(
    """alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t
    char16_t char32_t class compl concept const consteval constexpr constinit const_cast
    continue co_await co_return co_yield decltype default delete do double dynamic_cast
    else enum explicit export extern false float for friend goto if inline int long
    mutable namespace new noexcept not not_eq nullptr operator or or_eq private protected
    public register reinterpret_cast requires return short signed sizeof static
    static_assert static_cast struct switch template this thread_local throw true try
    typedef typeid typename union unsigned using virtual void volatile wchar_t while xor
    xor_eq final override import module""".split()
)
# Not keywords, but they would shadow what the header uses inside namespace ipgen::<name>.
RESERVED_NAMES: frozenset[str] = frozenset(
    {"std", "posix", "main", "Eigen", "ipgen", "Model", "Params", "Vector", "Matrix"}
)


def name_problem(name: str) -> str | None:
    """Why `name` cannot be a model name (a phrase to follow the name), or None if it can."""
    if not _IDENTIFIER.match(name) or "__" in name:
        return "is not a C++ identifier: use a letter, then letters, digits or '_' (no '__')"
    if name in CPP_KEYWORDS or name in RESERVED_NAMES:
        return "is reserved in C++ or by the generated header"
    return None
