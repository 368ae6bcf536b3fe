"""Control on top of the model: the linear model and LQR gains (`linear`, numpy and scipy) and
the controller a generated header or simulator runs (`controller`); swing-up (CasADi + IPOPT,
the extra `swingup`, pip install casadi): the exact model as CasADi functions (`casadi_model`),
trajectory planning (`trajectory`), time-varying LQR tracking and hold (`tvlqr`), both chained
(`swingup`), and Åström–Furuta energy control for single links (`energy`).
"""
