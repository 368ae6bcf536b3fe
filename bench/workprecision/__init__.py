"""Work–precision benchmark of ipsim's integrators against MuJoCo and scipy (`make bench`)."""
