"""ipgen benchmarks: generation time against sympy.physics.mechanics, evaluation time against Pinocchio."""
