"""Quasi-static large-deformation FEM reference for elastic contact (CPU only).

Compressible neo-Hookean linear tetrahedra + IPC log-barrier contact (ipctk) + projected Newton
with CCD-filtered backtracking line search. Produces intersection-free "ground truth" deformed
surfaces for comparing a geometric contact deformer against.

Scenes
  plane  : elastic sphere (radius R) pushed onto a rigid ground plane z=0.
           Top cap (z > zc + R - cap) is displaced by -delta (glued rigid platen).
           By symmetry this also equals two identical spheres pressed together (frictionless).
  spheres: elastic sphere A (radius R) on top of elastic sphere B (radius R2).
           A's top cap is displaced by -delta, B's bottom cap is fixed.

Outputs (in --out): step_XXX_A.obj (deformed surface of A), step_XXX_B.obj (scene spheres),
rest_A.obj, tets_A.npz (rest tet mesh), summary.csv.

usage:
  python ipc_sphere_contact.py --scene plane   --delta 0.3 --steps 6 --subdiv 3 --out out_plane
  python ipc_sphere_contact.py --scene spheres --delta 0.3 --steps 6 --subdiv 3 --R2 1.5 --out out_spheres
"""
import argparse, os, time, csv
import numpy as np, scipy.sparse as sp, scipy.sparse.linalg as spla
import trimesh, tetgen, ipctk

# ipctk 1.6.1: plane-vertex candidates are only collected for d < dhat/2 (the vertex box is inflated by dhat/2),
# while BarrierPotential(dhat) is non-zero up to d = dhat -> energy jumps when a vertex crosses dhat/2 and
# the line search stalls. Building the collision set with 2*dhat is harmless (the barrier is clamped to 0
# beyond dhat) and removes the discontinuity.
BUILD_DHAT = 2.01

# ----------------------------------------------------------------------------- meshing
def tet_sphere(R, center, subdiv, maxvol_scale=1.0, graded=None):
    if graded is None:
        s = trimesh.creation.icosphere(subdivisions=subdiv, radius=R)
    else:
        s = trimesh.Trimesh(*graded_sphere_surface(R, *graded), process=False)
    h = s.edges_unique_length.mean()
    tg = tetgen.TetGen(np.asarray(s.vertices, float), np.asarray(s.faces, np.int32))
    # nobisect => keep the input surface exactly (no Steiner points on the boundary)
    V, T = tg.tetrahedralize(order=1, nobisect=True, quality=True, minratio=1.5,
                             maxvolume=maxvol_scale * h ** 3 / 6 * 2.0)[:2]
    V = np.asarray(V, float) + np.asarray(center, float)
    T = np.asarray(T, np.int64)
    # orient tets positively
    d = np.einsum('ij,ij->i', np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), V[T[:, 3]] - V[T[:, 0]])
    T[d < 0] = T[d < 0][:, [0, 2, 1, 3]]
    return V, T

def graded_sphere_surface(R, h_min, h_max, theta_fine, growth):
    """A sphere surface of radius R (centre 0) whose edges are about h_min within the polar angle
    theta_fine of its top pole (+z) and grow by `growth` per unit of arc length beyond, up to h_max:
    rings of points at polar angles spaced by the local edge length (each ring turned by the golden
    angle, so no four points are cospherical by accident), triangulated by their convex hull."""
    from scipy.spatial import ConvexHull
    size = lambda th: min(h_max, h_min + growth * R * max(0.0, th - theta_fine))
    pts = [[0.0, 0.0, R]]
    th, k = 0.0, 0
    while True:
        th += size(th) / R
        if th > np.pi - 0.5 * size(th) / R:
            break
        k += 1
        n = max(6, int(round(2 * np.pi * R * np.sin(th) / size(th))))
        ph = 2 * np.pi * (np.arange(n) + (k * 0.6180339887) % 1.0) / n
        pts += np.stack([R * np.sin(th) * np.cos(ph), R * np.sin(th) * np.sin(ph), np.full(n, R * np.cos(th))], 1).tolist()
    pts.append([0.0, 0.0, -R])
    V = np.asarray(pts)
    F = ConvexHull(V).simplices.astype(np.int64)
    flip = np.einsum('ij,ij->i', np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), V[F].mean(1)) < 0
    F[flip] = F[flip][:, [0, 2, 1]]
    return V, F

def boundary_faces(T):
    f = np.vstack([T[:, [0, 2, 1]], T[:, [0, 1, 3]], T[:, [1, 2, 3]], T[:, [0, 3, 2]]])
    key = np.sort(f, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return f[cnt[inv.ravel()] == 1]          # outward oriented for positively oriented tets

def edges_of(F):
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)

# ----------------------------------------------------------------------------- elasticity
class NeoHookean:
    """Psi = mu/2 (I1-3) - mu lnJ + lam/2 (lnJ)^2, linear tets, vectorised."""
    def __init__(self, X, T, E, nu):
        self.T = T; self.n = len(X)
        self.mu = E / (2 * (1 + nu)); self.lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        Dm = np.stack([X[T[:, k]] - X[T[:, 0]] for k in (1, 2, 3)], axis=2)   # (t,3,3) columns
        self.vol = np.linalg.det(Dm) / 6.0
        assert (self.vol > 0).all()
        self.Dminv = np.linalg.inv(Dm)
        # gradN (t,4,3): gradients of the 4 barycentric shape functions
        g = self.Dminv                                          # row k = grad of N_{k+1} (F = Ds Dm^-1)
        self.gradN = np.concatenate([-g.sum(1, keepdims=True), g], axis=1)
        # B (t,9,12): dF_ij/dx_ak = delta_ik gradN_a[j]
        B = np.zeros((len(T), 9, 12))
        for a in range(4):
            for i in range(3):
                for j in range(3):
                    B[:, 3 * i + j, 3 * a + i] = self.gradN[:, a, j]
        self.B = B
        dof = (3 * T[:, :, None] + np.arange(3)).reshape(len(T), 12)
        self.rows = np.repeat(dof, 12, axis=1).ravel(); self.cols = np.tile(dof, (1, 12)).ravel()
        self.dof = dof

    def F(self, x):
        return np.einsum('tai,taj->tij', x[self.T], self.gradN)

    def min_J(self, x):
        return np.linalg.det(self.F(x)).min()

    def energy(self, x):
        F = self.F(x); J = np.linalg.det(F)
        if (J <= 0).any(): return np.inf
        lJ = np.log(J); I1 = np.einsum('tij,tij->t', F, F)
        return float(np.sum(self.vol * (0.5 * self.mu * (I1 - 3) - self.mu * lJ + 0.5 * self.lam * lJ ** 2)))

    def grad_hess(self, x, project=True):
        F = self.F(x); J = np.linalg.det(F); lJ = np.log(J)
        G = np.linalg.inv(F).transpose(0, 2, 1)                        # F^{-T}
        P = self.mu * (F - G) + self.lam * lJ[:, None, None] * G
        ge = self.vol[:, None] * np.einsum('tk,tkl->tl', P.reshape(-1, 9), self.B)
        g = np.zeros(3 * self.n); np.add.at(g, self.dof.ravel(), ge.ravel())
        # dP_ij/dF_kl = mu d_ik d_jl + (mu - lam lnJ) G_il G_kj + lam G_ij G_kl
        c = (self.mu - self.lam * lJ)[:, None, None, None, None]
        dP = (self.mu * np.einsum('ik,jl->ijkl', np.eye(3), np.eye(3))[None]
              + c * np.einsum('til,tkj->tijkl', G, G)
              + self.lam * np.einsum('tij,tkl->tijkl', G, G)).reshape(-1, 9, 9)
        He = self.vol[:, None, None] * np.einsum('tki,tkl,tlj->tij', self.B, dP, self.B)
        if project:
            w, Q = np.linalg.eigh(He)
            He = np.einsum('tij,tj,tkj->tik', Q, np.maximum(w, 0), Q)
        H = sp.csc_matrix((He.ravel(), (self.rows, self.cols)), shape=(3 * self.n, 3 * self.n))
        return g, H

# ----------------------------------------------------------------------------- solver
def solve(args):
    t_start = time.time()
    R = args.R
    bodies = []
    gap0 = 0.5 * args.dhat
    XA, TA = tet_sphere(R, [0, 0, R + gap0], args.subdiv)
    bodies.append(('A', XA, TA))
    if args.scene == 'spheres':
        graded = None
        if args.graded_B:
            h_min, h_max, theta_fine, growth = args.graded_B
            graded = (h_min, h_max, theta_fine, growth)
        XB, TB = tet_sphere(args.R2, [0, 0, -args.R2 - gap0], args.subdiv_B if args.subdiv_B is not None else args.subdiv,
                            graded=graded)
        bodies.append(('B', XB, TB))
    # assemble global mesh
    X = np.vstack([b[1] for b in bodies]); offs = np.cumsum([0] + [len(b[1]) for b in bodies])
    T = np.vstack([b[2] + o for b, o in zip(bodies, offs)])
    Fs = boundary_faces(T)
    mat = NeoHookean(X, T, args.E, args.nu)
    # Dirichlet sets
    zA = XA[:, 2]; topA = np.where(zA > zA.max() - args.cap * R)[0]
    fixed = [topA]; moving = topA
    if args.scene == 'spheres':
        zB = XB[:, 2]; fixed.append(np.where(zB < zB.min() + args.cap * args.R2)[0] + offs[1])
    fixed = np.unique(np.concatenate(fixed))
    free = np.setdiff1d(np.arange(3 * len(X)), (3 * fixed[:, None] + np.arange(3)).ravel())
    # collision mesh (surface only) + optional ground plane
    E_ = edges_of(Fs)
    cm = ipctk.CollisionMesh.build_from_full_mesh(X, E_.astype(np.int32), Fs.astype(np.int32))
    if args.scene == 'plane':
        cm.planes = [ipctk.Hyperplane(np.array([0., 0., 1.]), np.array([0., 0., 0.]))]
    bbox = np.linalg.norm(X.max(0) - X.min(0))
    dhat = args.dhat
    # barrier stiffness. ipctk's barrier acts on SQUARED distances: b(s)=-(s-dhat^2)^2 ln(s/dhat^2), so the
    # contact force at d=dhat/2 is ~4.3*kappa*dhat^3. Choose it ~ kappa_scale * E * (mean face area).
    Fa = np.linalg.norm(np.cross(X[Fs[:, 1]] - X[Fs[:, 0]], X[Fs[:, 2]] - X[Fs[:, 0]]), axis=1).mean() / 2
    kappa = args.kappa_scale * args.E * Fa / (4.3 * dhat ** 3)
    B = ipctk.BarrierPotential(dhat, kappa)
    print(f'scene={args.scene} nodes={len(X)} tets={len(T)} surf_faces={len(Fs)} fixed_nodes={len(fixed)} dhat={dhat:g} kappa={kappa:.4g} '
          f'mu={mat.mu:.4g} lam={mat.lam:.4g}  (mesh {time.time()-t_start:.2f}s)')
    os.makedirs(args.out, exist_ok=True)
    np.savez(os.path.join(args.out, 'tets.npz'), X=X, T=T, F=Fs, offs=offs, fixed=fixed)
    surfA = Fs[np.all(Fs < offs[1], axis=1)]
    def dump(x, tag):
        for name, lo, hi in [(b[0], offs[k], offs[k + 1]) for k, b in enumerate(bodies)]:
            Fb = Fs[np.all((Fs >= lo) & (Fs < hi), axis=1)] - lo
            used = np.unique(Fb); remap = -np.ones(hi - lo, int); remap[used] = np.arange(len(used))
            with open(os.path.join(args.out, f'{tag}_{name}.obj'), 'w') as f:
                f.write(''.join(f'v {a:.9g} {b:.9g} {c:.9g}\n' for a, b, c in x[lo:hi][used]))
                f.write(''.join(f'f {i+1} {j+1} {k+1}\n' for i, j, k in remap[Fb]))
    dump(X, 'rest')
    vol0 = mat.vol.sum()
    x = X.copy()
    rows = []
    for step in range(1, args.steps + 1):
        t0 = time.time()
        delta = args.delta * step / args.steps
        # predictor: move the Dirichlet cap to its new height and spread the increment linearly (in z) over
        # body A down to 0.3R above its lowest point, so the contact region is untouched (stays
        # intersection-free) and no element is inverted by the increment.
        inc = (X[moving, 2] - delta) - x[moving, 2]            # (negative) increment of the cap this step
        xa = x[:offs[1]]; zlo = xa[:, 2].min() + 0.3 * R; zcap = x[moving, 2].min()
        w = np.clip((xa[:, 2] - zlo) / max(zcap - zlo, 1e-9), 0, 1)
        xp = x.copy(); xp[:offs[1], 2] += w * inc.mean(); xp[moving, 2] = X[moving, 2] - delta
        if not ipctk.is_step_collision_free(cm, cm.vertices(x), cm.vertices(xp)) or mat.min_J(xp) <= 0:
            raise RuntimeError('predictor not feasible: use more --steps')
        x = xp
        def total(xx):
            e = mat.energy(xx)
            if not np.isfinite(e): return np.inf
            V = cm.vertices(xx); col = ipctk.NormalCollisions(); col.build(cm, V, BUILD_DHAT * dhat)
            return e + B(col, cm, V)
        it = 0
        for it in range(1, args.max_newton + 1):
            V = cm.vertices(x); col = ipctk.NormalCollisions(); col.build(cm, V, BUILD_DHAT * dhat)
            g, H = mat.grad_hess(x)
            gb = cm.to_full_dof(B.gradient(col, cm, V))
            Hb = cm.to_full_dof(B.hessian(col, cm, V, project_hessian_to_psd=ipctk.PSDProjectionMethod.CLAMP))
            g = g + gb; H = (H + Hb).tocsc()
            Hff = H[free][:, free]
            dx = np.zeros_like(g)
            dx[free] = spla.spsolve(Hff + 1e-12 * sp.eye(len(free)), -g[free])
            dX = dx.reshape(-1, 3)
            if np.abs(dX).max() < args.tol * R:
                break
            # CCD-filtered step + energy backtracking (also rejects inverted tets)
            alpha = min(1.0, 0.9 * ipctk.compute_collision_free_stepsize(cm, cm.vertices(x), cm.vertices(x + dX)))
            if args.scene == 'plane':   # explicit vertex/plane CCD (plane z=0), keep 10% of the gap
                sv = np.unique(Fs); dz = dX[sv, 2]; m_ = dz < 0
                if m_.any(): alpha = min(alpha, 0.9 * np.min(x[sv[m_], 2] / -dz[m_]))
            e0 = total(x)
            while alpha > 1e-10:
                xn = x + alpha * dX
                if total(xn) <= e0 + 1e-4 * alpha * g.dot(dx): break
                alpha *= 0.5
            x = xn
            if args.verbose: print(f'    it={it} |dx|inf={np.abs(dX).max():.3e} |g_free|={np.linalg.norm(g[free]):.3e} alpha={alpha:.3e} ncol={len(col)}')
        # measurements
        V = cm.vertices(x); col = ipctk.NormalCollisions(); col.build(cm, V, BUILD_DHAT * dhat)
        g_el, _ = mat.grad_hess(x, project=False)
        force = -g_el.reshape(-1, 3)[moving, 2].sum()          # reaction on the moving cap (N, upward = compressive)
        vol = np.abs(np.linalg.det(mat.F(x))) @ mat.vol
        # contact zone of A: surface vertices of A within contact_tol of the obstacle
        sA = np.unique(surfA)
        if args.scene == 'plane':
            gapv = x[sA, 2]
        else:
            import igl
            FB = (Fs[np.all(Fs >= offs[1], axis=1)] - offs[1]).astype(np.int64)
            d2 = igl.point_mesh_squared_distance(x[sA], x[offs[1]:], FB)[0]
            gapv = np.sqrt(d2)
        inc = sA[gapv < args.contact_tol * R]
        r_contact = np.hypot(x[inc, 0], x[inc, 1]).max() if len(inc) else 0.0
        min_gap = gapv.min()
        bulge = np.hypot(x[sA, 0], x[sA, 1]).max() - R
        dt = time.time() - t0
        c_idx = np.argmin(np.linalg.norm(XA - XA.mean(0), axis=1))   # node nearest to A's rest centre
        center_approach = X[c_idx, 2] - x[c_idx, 2]                 # effective rigid approach for a geometric deformer
        center_drop_B = 0.0
        if args.scene == 'spheres':                                 # B's centre moves too (B is squeezed on its fixed cap)
            b_idx = offs[1] + np.argmin(np.linalg.norm(XB - XB.mean(0), axis=1))
            center_drop_B = X[b_idx, 2] - x[b_idx, 2]
        row = dict(step=step, delta=delta, center_approach=center_approach, center_drop_B=center_drop_B, newton_iters=it, force=force, contact_radius=r_contact,
                   n_contact_verts=len(inc), min_gap=min_gap, max_radial_bulge=bulge,
                   rel_volume_change=vol / vol0 - 1, min_J=mat.min_J(x), seconds=dt)
        rows.append(row)
        print(' '.join(f'{k}={v:.5g}' if isinstance(v, float) else f'{k}={v}' for k, v in row.items()), flush=True)
        dump(x, f'step_{step:03d}')
    with open(os.path.join(args.out, 'summary.csv'), 'w', newline='') as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0])); w.writeheader(); w.writerows(rows)
    # Hertz reference (small strain, frictionless): a = (3 F R_eff / (4 E*))^(1/3)
    Es = args.E / (1 - args.nu ** 2)
    if args.scene == 'plane': Reff, Estar = R, Es
    else: Reff, Estar = R * args.R2 / (R + args.R2), Es / 2
    for r in rows:
        a_h = (3 * max(r['force'], 0) * Reff / (4 * Estar)) ** (1 / 3)
        print(f"  step {r['step']}: F={r['force']:.4g}  contact radius FEM={r['contact_radius']:.4f}  Hertz(F)={a_h:.4f}")
    print(f'total {time.time()-t_start:.1f}s')

if __name__ == '__main__':
    ap = argparse.ArgumentParser()
    ap.add_argument('--scene', choices=['plane', 'spheres'], default='plane')
    ap.add_argument('--R', type=float, default=1.0); ap.add_argument('--R2', type=float, default=1.0)
    ap.add_argument('--E', type=float, default=1e5); ap.add_argument('--nu', type=float, default=0.45)
    ap.add_argument('--delta', type=float, default=0.2, help='total downward displacement of the top cap')
    ap.add_argument('--steps', type=int, default=5); ap.add_argument('--subdiv', type=int, default=3)
    ap.add_argument('--subdiv-B', dest='subdiv_B', type=int, default=None)
    ap.add_argument('--graded-B', dest='graded_B', type=float, nargs=4, default=None,
                    metavar=('H_MIN', 'H_MAX', 'THETA_FINE', 'GROWTH'),
                    help="B's surface graded instead of an icosphere: edges H_MIN within the polar angle THETA_FINE "
                         "(radians) of its top, growing by GROWTH per unit of arc beyond, up to H_MAX")
    ap.add_argument('--cap', type=float, default=0.15, help='Dirichlet cap height as a fraction of R')
    ap.add_argument('--dhat', type=float, default=1e-3); ap.add_argument('--kappa-scale', type=float, default=0.1)
    ap.add_argument('--tol', type=float, default=1e-5); ap.add_argument('--max-newton', type=int, default=60)
    ap.add_argument('--contact-tol', type=float, default=2e-3, help='gap (fraction of R) counted as contact')
    ap.add_argument('--out', default='out'); ap.add_argument('--verbose', action='store_true')
    solve(ap.parse_args())
