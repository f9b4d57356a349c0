import time, numpy as np, rolling_disk_env as rd
from rolling_disk_env.integrators import simulate_contact
x0 = np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0.0])
for tol in (1e-10, 1e-12, 1e-13):
    t=time.time()
    tr = simulate_contact(x0, 10, 0.01, method="dop853", contact="sliding", friction_coefficient=0.0, rtol=tol, atol=tol)
    E = rd.sliding_energy(tr.states)
    print(tol, "time", time.time()-t, "drift", np.abs(E-E[0]).max())
t=time.time(); rd.simulate(x0, 10, 0.01, method="dop853"); print("rolling dop853", time.time()-t)
t=time.time(); tr=simulate_contact(x0, 10, 0.01, method="dop853", contact="coulomb", friction_coefficient=10); print("coulomb dop853", time.time()-t)
