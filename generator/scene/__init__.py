"""Scene files (TOML), read and checked: their format declared once (`schema`, on pydantic's own
types and the two kinds of `values`, with ipgen's own rules in `checks`, `controller`, `swingup`
and `sensors`), loaded into a validated document (`load`, its messages' helpers in `fields`).
The `experiment` stage resolves a document into a `Scene`; docs/scenes.md is the reference.
"""
