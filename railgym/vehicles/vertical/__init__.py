"""Vertical (bounce) model of one bogie and its share of the carbody, paper fig. 2, eq. (1)–(2).

Bogie frame ``m1`` on the primary suspension ``k1, c1`` (track side), carbody share ``m2`` on
the secondary suspension; ``x1, x2`` are measured upwards from the loaded static equilibrium
(gravity is balanced by the air-spring preload), ``δ = x1 − x2`` (> 0: compression)::

    m1·ẍ1 = k1·z + c1·ż − k1·x1 − c1·ẋ1 − F_s − F_a
    m2·ẍ2 = F_s + F_a

``f(t) = k1·z + c1·ż`` is the track input (eq. 1), ``F_s`` the secondary-suspension force and
``F_a`` an actuator force between bogie and carbody, held constant over a control interval.

Secondary-suspension variants (``VARIANTS``), each with a numba kernel ``advance_<variant>``:

``"linear"``
    ``F_s = k2·δ + c2·δ̇`` (eq. 1).
``"static"``
    memoryless reference ``F_s = k2·δ·(1 + a·δ²) + F_bump(δ) + F_damper(δ̇)``: progressive
    spring, bump stops beyond the free travel (C1 ramp of ``10·k2`` plus a cubic term),
    asymmetric two-slope damper with a hyperbolic blow-off knee.
``"dynamic"`` (default reference)
    air spring with a surge reservoir joined by an orifice (Nishimura/Berg family: Berg 1999,
    *Vehicle System Dynamics* 33 sup1, 528–539; Docquier, Fisette & Jeanmart 2007, *VSD*
    45(6), 505–524; review: Bruni et al. 2011, *VSD* 49(7), 1021–1072), the same bump stops,
    and the damper in series with its bush/oil stiffness ``k_b`` (Maxwell element). States
    ``[x1, v1, x2, v2, Δp_b, Δp_r, y]`` with the bag and reservoir pressures as deviations
    from the static pressure ``p0`` (Pa) and ``y`` the damper's internal displacement (m):

    * gas: polytropic, ``ρ(p) = ρ0·(p/p0)^(1/n)``; for each volume
      ``ṗ = n·p·(ṁ/(ρ·V) − V̇/V)``, which conserves the total gas mass;
    * bag volume ``V_b = V_b0 − A0·δ − ½·A'·δ²``, effective area ``A_e = A0 + A'·δ``;
    * orifice mass flow bag → reservoir
      ``q = C_d·A_o·√(2ρ̄)·Δp / (Δp² + Δp_l²)^(1/4)``: turbulent ``√|Δp|`` law, laminar
      (linear) below ``Δp_l``, ``ρ̄`` the mean density of both volumes;
    * force ``count·[(p_b − p_atm)·A_e(δ) − (p0 − p_atm)·A0]`` (preload removed);
    * damper ``F_d = k_b·(δ − y) = F_damper(ẏ)``, so ``ẏ = F_damper⁻¹(F_d)`` (closed-form
      inverse of the hyperbolic-knee curve).

    The quasi-static stiffness ``count·(n·p0·A0²/(V_b+V_r) + (p0−p_atm)·A')`` is designed to
    equal ``k2``; with the orifice closed it is ``count·(n·p0·A0²/V_b + (p0−p_atm)·A')``. The
    Maxwell damper turns into a spring above ``k_b/(2π·c)``. Measured stiffness and loss
    angles are in ``docs/envs/vertical.md``.
``"surrogate"``
    ``F_s = F̂(δ, δ̇)`` from a fitted LPR model via :func:`surrogates.models.lpr.lpr_eval_into`
    (eq. 2; work array allocated once per kernel call). Out-of-domain inputs are counted per
    RK4 stage evaluation (4 per substep).

Integration: classic fixed-step RK4; the track is sampled on ``t_k = k·dt`` and the stages at
``t + dt/2`` use the cubic Hermite midpoint of samples ``k`` and ``k + 1``,
``z_m = (z_k + z_{k+1})/2 + dt·(ż_k − ż_{k+1})/8`` and
``ż_m = 3(z_{k+1} − z_k)/(2dt) − (ż_k + ż_{k+1})/4`` (errors for a sine (ω·dt)⁴/384 and
(ω·dt)⁴/1920 of its amplitudes), so a sampled smooth input keeps RK4's 4th order. The linear
model converges with order 4, the nonlinear ones with order ≈ 2: their right-hand sides are
not smooth (the damper's slope jumps at δ̇ = 0, the bump-stop onset is only C1). The step
``DEFAULT_DT`` and its measured convergence and cost are in ``docs/envs/vertical.md``.

A controllable damper between bogie and carbody (:class:`DamperLaw`: the exact law of
:mod:`railgym.vehicles.semi_active` or its data-driven element,
:mod:`railgym.vehicles.semi_active_element`) takes the actuator's place in
:func:`advance_semi_active` (any variant, scalar path): ``F_a`` is then its force, its states
(``u`` and ``w``, or ``u`` and the element's memory ``m``) are the last two columns of the
state (``state_size(..., damper=True)``).

Per control step the kernels also report the bump-stop contact count (substeps whose end
state is beyond the free travel, for every variant: a geometric measure), the out-of-domain
count (surrogate only) and a diverged flag: when a substep yields a non-finite state or
``|x1|`` or ``|x2|`` above ``DIVERGENCE_DISPLACEMENT``, the state is frozen at the last finite
value, the outputs are zero and the flag is set; NaN never enters the state.

Modules: :mod:`~railgym.vehicles.vertical.params` (vehicle data, YAML loading),
:mod:`~railgym.vehicles.vertical.elements` (element laws), :mod:`~railgym.vehicles.vertical.kernels`
(RK4 step kernels), :mod:`~railgym.vehicles.vertical.simulate` (recorded runs); import each
name from its module.
"""
