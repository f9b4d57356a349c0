import numpy as np, rolling_disk_env as rd
from rolling_disk_env.integrators import simulate_contact
S2 = np.array([2, 0, 0, 0.5, 0, rd.steady_motion(0.5, 1.0), 0, 1.0])
ref = simulate_contact(S2, 3, 0.01, method="dop853", contact="coulomb", friction_coefficient=0.3, rtol=1e-12, atol=1e-12)
print([(e.time, e.kind) for e in ref.events])
for dt in (0.01, 0.005, 0.0025):
    tr = simulate_contact(S2, 3, dt, method="rk4", contact="coulomb", friction_coefficient=0.3)
    step = int(round(0.01/dt))
    err = np.abs(tr.states[::step] - ref.states).max(axis=1)
    print(dt, [(e.time, e.kind) for e in tr.events], "err@1.5", err[150], "err@1.8", err[180], "err@3", err[-1])
