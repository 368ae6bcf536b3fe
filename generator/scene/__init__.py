"""Scene files (TOML): their format declared once (`schema`, on pydantic's own types and the
two kinds of `values`, with ipgen's own rules in `checks`, `controller` and `swingup`), read in
three steps (`load`: file to validated document, with the linear pre-parse check `nesting` and
the message helpers `fields`; `resolve`: the `Scene`; `config`: the simulator's .cfg), what a
specialised scene folds (`specialisation`), and editing scenes (`update`, `experiment`).
docs/scenes.md is the reference for users.
"""
