import numpy as np, rolling_disk_env as rd
from rolling_disk_env.integrators import simulate_contact
S2 = np.array([2, 0, 0, 0.5, 0, rd.steady_motion(0.5, 1.0), 0, 1.0])
x = rd.sliding_state(S2); x[5] += 0.5  # slipping
for mu in (0.0, 0.3):
    ref = simulate_contact(x, 1.5, 0.01, method="dop853", contact="sliding", friction_coefficient=mu, rtol=1e-13, atol=1e-13)
    print(mu, ref.events)
    for dt in (0.01, 0.005, 0.0025):
        tr = simulate_contact(x, 1.5, dt, method="rk4", contact="sliding", friction_coefficient=mu)
        step = int(round(0.01/dt))
        print(dt, np.abs(tr.states[::step] - ref.states).max())
ref = simulate_contact(x, 1.5, 0.01, method="dop853", contact="sliding", friction_coefficient=0.3, rtol=1e-13, atol=1e-13)
tr = simulate_contact(x, 1.5, 0.0025, method="rk4", contact="sliding", friction_coefficient=0.3)
v = rd.slip_velocity(ref.states); v2 = rd.slip_velocity(tr.states[::4])
for i in range(0, 151, 10):
    print(ref.times[i], v[i], v2[i], ref.states[i,3], tr.states[4*i,3])
