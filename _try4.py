import numpy as np, rolling_disk_env as rd
from rolling_disk_env._generated import sliding as S
S2 = np.array([2, 0, 0, 0.5, 0, rd.steady_motion(0.5, 1.0), 0, 1.0])
x = rd.sliding_state(S2); m,g,r = 5.0, 9.81, 1.0
lam = rd.contact_force(S2); N = rd.normal_force(S2)
def slip_acc(f):
    d = np.array(S.friction_derivative(tuple(x), 0.0, 0.0, f[0], f[1], m, g, r))
    e = 1e-6
    vp = np.array(S.slip_velocity(tuple(x + e*d), r)); vm = np.array(S.slip_velocity(tuple(x - e*d), r))
    return (vp - vm)/(2*e)
print("lam", lam, "ratio", np.hypot(*lam)/N)
print("a_s with needed force", slip_acc(lam/N))
mu = 0.3
e = lam/np.hypot(*lam)
print("a_s with mu lam_hat", slip_acc(mu*e), "dir", slip_acc(mu*e)/np.linalg.norm(slip_acc(mu*e)), "vs -lam_hat", -e)
for i in range(50):
    a = slip_acc(mu*e); e = -a/np.linalg.norm(a)
print("consistent friction dir", e, "lam_hat", lam/np.hypot(*lam))
# Delassus: a_s(f) affine in f? check
for f in [np.array([0.1,0]), np.array([0,0.1]), np.array([0,0])]:
    print(f, slip_acc(f))
