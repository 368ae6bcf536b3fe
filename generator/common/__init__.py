"""Small helpers every stage shares: input limits (`limits`), safe text in messages and
generated comments (`safetext`), model names (`naming`).
"""
