"""Renders a model behind ipgen's C model interface (`--emit library`, templates/model_library.c.jinja).

Two files: the model's C99 header (`c_header.py`, the model's functions only: no controller,
swing-up or estimator, which belong to a scene's loop) and `NAME_model.c`, a thin adapter that
fills the interface's struct (cpp/include/ipgen_model.h) with the header's functions. Compiled
into a shared library, it is what ipsim's simulator, compiled once, loads at run time.
"""

from __future__ import annotations

from dataclasses import replace

from ipgen.codegen.c_header import c_number, render_c_header
from ipgen.codegen.functions import C_SYNTAX
from ipgen.codegen.header import HeaderRequest, environment, folded_entries, header_context, rod_fills
from ipgen.model.coordinates import Coordinates
from ipgen.model.derivation import Equations

TEMPLATE = "model_library.c.jinja"
SUFFIX = "_model.c"


def model_only(request: HeaderRequest) -> HeaderRequest:
    """`request` without what a scene's loop adds to the C header (controller, swing-up,
    estimator) and in ipgen's own coordinates: the model library's header depends on the model
    alone, so every scene of one model shares one compiled library."""
    return replace(request, controller=None, swingup=None, estimator=None, coordinates=Coordinates())


def render_model_library(eqs: Equations, request: HeaderRequest) -> dict[str, str]:
    """{".h": the model's C header, "_model.c": its adapter to ipgen_model.h}; deterministic."""
    request = model_only(request)
    header = render_c_header(eqs, request)
    spec = request.specialisation
    context = header_context(eqs, request, TEMPLATE)
    context["nameu"] = request.name.upper()
    context["fn"] = set(spec.outputs)  # the header's functions: the adapter fills those it has
    context["rod_fills"] = rod_fills(eqs.system, spec, C_SYNTAX)
    context["folded"] = folded = folded_entries(eqs.system, spec, C_SYNTAX, lambda v: c_number(float(v)))
    context["folded_rod"] = any(rod for *_, rod in folded)
    return {".h": header, SUFFIX: environment().get_template(TEMPLATE).render(context)}
