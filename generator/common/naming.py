"""C and C++ naming rules for model names: a name becomes the namespace `ipgen::<name>`, the file
`<name>.hpp` (and, for `--emit c`, `<name>.h` with `ipgen_<name>_*` functions and
`IPGEN_<NAME>_*` macros), so it must be an identifier that no standard header, Eigen or the
generated header itself defines.
"""

from __future__ import annotations

import re

from ipgen.common.limits import MAX_NAME_LENGTH

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
# C99/C11 keywords the C++ list lacks.
C_KEYWORDS: frozenset[str] = frozenset("restrict _Bool _Complex _Imaginary _Alignas _Noreturn".split())
# Macros with lower-case letters in their name that the C and C++ standard libraries (with
# glibc's POSIX and GNU extensions, which g++ always enables) and Eigen define. Upper-case
# macros (NULL, EOF, INFINITY, EDOM, SIGINT, INT_MAX, ...) are refused by the rule that a
# name must contain a lower-case letter; families are in _MACRO_PATTERNS.
STANDARD_MACROS: frozenset[str] = frozenset(
    """assert errno stdin stdout stderr offsetof setjmp sigsetjmp longjmp va_arg va_copy va_end
    va_start bool true false complex imaginary alignas alignof noreturn static_assert
    thread_local and and_eq bitand bitor compl not not_eq or or_eq xor xor_eq
    fpclassify isfinite isinf isnan isnormal issubnormal signbit isgreater isgreaterequal isless
    islessequal islessgreater isunordered math_errhandling
    acos acosh asin asinh atan atan2 atanh carg cbrt ceil cimag conj copysign cos cosh cproj
    creal erf erfc exp exp2 expm1 fabs fdim floor fma fmax fmin fmod frexp hypot ilogb ldexp
    lgamma llrint llround log log10 log1p log2 logb lrint lround nearbyint nextafter nexttoward
    pow remainder remquo rint round scalb scalbln scalbn sin sinh sqrt tan tanh tgamma trunc
    isalnum isalpha isascii isblank iscntrl isdigit isgraph islower isprint ispunct isspace
    isupper isxdigit toascii tolower toupper getc putc getchar putchar
    alloca strdupa strndupa assert_perror linux unix i386 major minor makedev
    be16toh be32toh be64toh htobe16 htobe32 htobe64 htole16 htole32 htole64 le16toh le32toh
    le64toh sigmask timerclear timercmp timerisset timeradd timersub
    eigen_assert eigen_internal_assert eigen_plain_assert""".split()
)
_MACRO_PATTERNS = re.compile(
    r"(?:PRI|SCN)[a-zX]|M_[0-9A-Z]|[LP]_[a-z]|(?:si|sa|sigev|sched)_[a-z]|pthread_|vec\d+[a-z]_"
    r"|ei_|EIGEN|[A-Za-z]+_l\Z|(?i:ipgen)"
)
# Not keywords, but they would shadow what the header uses inside namespace ipgen::<name>, or
# are the names the header itself defines there.
RESERVED_NAMES: frozenset[str] = frozenset(
    {"std", "posix", "main", "Eigen", "ipgen", "detail"}
    | {"Model", "Params", "Vector", "Matrix", "Derivatives", "Scalar"}
    | {"kLinks", "kDof", "kSpecialised", "kName", "kType", "kInertia", "check_folded"}
    | {"DcMotor", "with_motor", "with_rod_links", "forward_dynamics_acceleration", "linearize_acceleration"}
    | {"canonical", "to_canonical", "from_canonical", "rates_to_canonical", "rates_from_canonical"}
    | {"forces_from_canonical", "congruence", "similarity"}
    | {"mass_matrix", "bias", "gravity", "n_matrix", "forward_dynamics", "forward_dynamics_derivatives"}
    | {"kinetic_energy", "potential_energy", "dissipation", "factorize_ldlt", "solve_ldlt"}
    | {"linearize", "Linearization", "StateVector", "StateMatrix"}
)

# C headers a folder holding NAME.h would hide from a compiler given that folder (-I, CMake's
# include directories): C11's, and the POSIX and glibc ones programs around ipgen include.
HEADER_STEMS: frozenset[str] = frozenset(
    """assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal
    stdalign stdarg stdatomic stdbool stddef stdint stdio stdlib stdnoreturn string tgmath
    threads time uchar wchar wctype unistd fcntl dlfcn pthread sched strings memory malloc
    endian features poll termios""".split()
)


def macro_problem(name: str) -> str | None:
    """Why `name` collides (or may collide) with a macro, or None."""
    if not any(ch.islower() for ch in name):
        return "has no lower-case letter, the form of C macros (NULL, EOF, INT_MAX): use lower case"
    if name in STANDARD_MACROS or _MACRO_PATTERNS.match(name):
        return "is a macro of the C or C++ standard library, glibc, Eigen or ipgen"
    return None


def name_problem(name: str) -> str | None:
    """Why `name` cannot be a model name (a phrase to follow the name), or None if it can."""
    if len(name) > MAX_NAME_LENGTH:
        return f"is {len(name)} characters long: use at most {MAX_NAME_LENGTH}"
    if not _IDENTIFIER.match(name) or "__" in name:
        return "is not a C++ identifier: use a letter, then letters, digits or '_' (no '__')"
    if name in CPP_KEYWORDS or name in C_KEYWORDS or name in RESERVED_NAMES:
        return "is reserved in C++ or by the generated header"
    if name in HEADER_STEMS:
        return f"would write {name}.h, hiding the C library's <{name}.h> from a compiler given its folder"
    return macro_problem(name)
