"""Control on top of the model: the linear model and LQR gains (`linear`, numpy and scipy) and
the controller a generated header or simulator runs (`controller`).
"""
