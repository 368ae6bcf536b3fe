"""Small helpers every stage shares: input limits (`limits`), safe text in messages and
generated comments (`safetext`), model names (`naming`), a TOML text's shape checked before
parsing (`toml_shape`) and TOML edited with its comments kept (`toml_edit`).
"""
