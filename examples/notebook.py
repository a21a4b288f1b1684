"""A notebook's worth of lobe from Python: a lobe table, an albedo curve, a sweep of parameter
sets in one call and a fit, plotted with matplotlib when it is installed.

    pip install .            # at the repository's root
    python examples/notebook.py [--cpu]

Each cell below stands alone in a notebook; run as a script it prints what it finds and, with
matplotlib, writes notebook.png beside the working folder.
"""

import sys

import numpy as np

import lobe

# %% A session: the GPU (lavapipe where there is none), or the f64 reference.
s = lobe.Session(backend="cpu" if "--cpu" in sys.argv else "gpu")
print("backend:", s.backend)
print("models:", ", ".join(m["name"] for m in lobe.models()))

# %% A lobe table of gold, isotropic grid: f[theta_i, theta_o, delta_phi, rgb].
table = s.table("cook_torrance", grid="isotropic", res=(45, 90, 90), material="gold",
                params={"roughness": 0.3})
f = table.values
theta_i, theta_o = table.axes["theta_i"], table.axes["theta_o"]
k = np.searchsorted(theta_i, np.radians(30))
# The mirror direction lies at delta_phi = pi: the last delta_phi cell.
print(f"table {f.shape} {f.dtype}; theta_i = {np.degrees(theta_i[k]):.1f} deg peaks at",
      f"theta_o = {np.degrees(theta_o[f[k, :, -1, 0].argmax()]):.1f} deg")

# %% Directional albedo E(mu) with its error estimate.
mu = np.linspace(0.02, 1.0, 50)
e, err = s.albedo("microfacet", mu=mu, params={"alpha": 0.3})
print(f"E(mu) of GGX alpha = 0.3: {e[0, 0]:.4f} (grazing) .. {e[-1, 0]:.4f} (normal),",
      f"largest error estimate {err.max():.1e}")

# %% Many parameter sets in one call: E(mu = 0.5) against roughness under the white furnace
# (Fresnel = 1), so that 1 - E is the energy single scattering loses.
alphas = np.linspace(0.05, 1.0, 40)
sweep = s.albedo("microfacet", mu=[0.5], params=[{"alpha": a} for a in alphas], white_furnace=True)
print(f"energy lost by single scattering at mu = 0.5: {1 - sweep.albedo[:, 0, 0].max():.3f} ..",
      f"{1 - sweep.albedo[:, 0, 0].min():.3f}")

# %% A fit: GGX's alpha and specular colour closest to Cook-Torrance gold.
fit = s.fit("cook_torrance", "microfacet", free=["alpha", "specular"],
            target_params={"roughness": 0.3}, max_iters=100, max_bins=4096)
print(f"fit: alpha = {fit.params['alpha']:.4f}, loss {fit.loss:.3e}, per channel {fit.channel_loss}")

# %% Plots, where matplotlib is installed.
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plots (pip install matplotlib)")
    sys.exit(0)

fig, ax = plt.subplots(1, 3, figsize=(13, 4))
ax[0].plot(np.degrees(theta_o), f[k, :, -1, :])
ax[0].set(title=f"gold, theta_i = {np.degrees(theta_i[k]):.0f} deg, delta_phi ~ 180 deg",
          xlabel="theta_o (deg)", ylabel="f (1/sr)")
ax[1].plot(mu, e[:, 0], label="E(mu)")
ax[1].fill_between(mu, e[:, 0] - err[:, 0], e[:, 0] + err[:, 0], alpha=0.3)
ax[1].set(title="GGX alpha = 0.3", xlabel="mu = cos theta_o", ylabel="directional albedo")
ax[2].plot(alphas, sweep.albedo[:, 0, 0])
ax[2].set(title="E(mu = 0.5), white furnace, against alpha", xlabel="alpha", ylabel="albedo")
fig.tight_layout()
fig.savefig("notebook.png", dpi=100)
print("wrote notebook.png")
