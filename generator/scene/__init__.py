"""Scene files (TOML): their format (`schema`), reading and checking them (`reader`, `fields`,
`controller`), and what a specialised scene folds (`specialisation`).
"""
