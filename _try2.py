import time, numpy as np, rolling_disk_env as rd
from rolling_disk_env.integrators import simulate_contact
S2 = np.array([2, 0, 0, 0.5, 0, rd.steady_motion(0.5, 1.0), 0, 1.0])
tr = simulate_contact(S2, 6, 0.05, method="dop853", contact="coulomb", friction_coefficient=0.3)
v = np.hypot(*rd.slip_velocity(tr.states).T)
E = rd.sliding_energy(tr.states)
N = rd.sliding_normal_force(tr.states, friction_coefficient=0.3)
for i in range(0, len(tr.times), 4):
    print(f"{tr.times[i]:.2f} slip {v[i]:.4f} theta {tr.states[i,3]:.4f} E {E[i]:.6f} N {N[i]:.3f} dphi {tr.states[i,7]:.3f} dpsi {tr.states[i,9]:.3f} speed {np.hypot(*tr.states[i,5:7]):.3f}")
print(tr.events)
mask = tr.times > 1.9
req = rd.required_friction(tr.states[mask][:, [0,1,2,3,4,7,8,9]])
print("max required after stick", req.max())
tr2 = simulate_contact(S2, 6, 0.001, method="dop853", contact="coulomb", friction_coefficient=0.3)
mask = tr2.times > 1.84
req = rd.required_friction(tr2.states[mask][:, [0,1,2,3,4,7,8,9]])
print("max required after stick (fine)", req.max(), tr2.events[0].time)
tr3 = simulate_contact(S2, 6, 0.001, method="rk4", contact="coulomb", friction_coefficient=0.3)
print("rk4 events", [(e.time, e.kind) for e in tr3.events], np.abs(tr3.states - tr2.states).max())
tr4 = simulate_contact(S2, 6, 0.01, method="dopri5", contact="coulomb", friction_coefficient=0.3)
print("dopri5 events", [(e.time, e.kind) for e in tr4.events], np.abs(tr4.states - tr2.states[::10]).max())
