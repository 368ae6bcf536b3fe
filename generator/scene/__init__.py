"""Scene files (TOML): their format declared once (`schema`, with the kinds of value in
`fieldtypes` and ipgen's own rules in `checks` and `controller`), reading them (`reader`, with
the linear pre-parse check `nesting` and the message helpers `fields`), and what a specialised
scene folds (`specialisation`). docs/scenes.md is the reference for users.
"""
