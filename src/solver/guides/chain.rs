//! Guide strands as serial multibody chains in generalized coordinates (Chang, Jin, Yu 2002,
//! §3.1–3.2), integrated with Featherstone's articulated-body algorithm.
//!
//! Link `i` of a guide is the segment from vertex `i` to vertex `i + 1`; its joint sits at
//! vertex `i` and has two rotational degrees of freedom, no twist (§3.1: "twisting of a hair
//! strand along its axis is prohibited", two cascading 1-D revolute joints). The link frame has
//! its `y` axis along the segment; the child frame is `parent · R₀ · J`, with `R₀` the rest
//! rotation from the parent frame and `J` the joint's rotation (identity at rest).
//!
//! The joint state is kept as the rotation `J` itself (a unit quaternion), not as two angles:
//! the joint's two degrees of freedom are its rates of swing about the link's own `x` and `z`
//! axes (the two axes perpendicular to the segment, in the *current* frame), so the relative
//! angular velocity never has a component along the segment (no twist) and no chart of angles
//! ever reaches a singularity (an `Rx(a)·Rz(b)` chart has a gimbal lock at `b = ±π/2`, where `a`
//! turns the segment about itself). A step turns `J` by `exp(h (ȧ, 0, ḃ))` in the link frame.
//! The actuator (§3.2: a hinge spring with damping towards the rest angles) is the spring
//! `½ k |log J|²`; its generalized force is `−k` times the swing part of `log J`, and it is
//! integrated implicitly together with the damping. Positions come from the rotations by
//! forward kinematics, so segment lengths are exact by construction.
//!
//! Spatial vectors are Plücker coordinates at the world origin, `(angular; linear)`; a link
//! lumps its mass at its end vertex with a small isotropic rotational inertia about it (the
//! cluster's thickness; it also keeps the joint-space inertia invertible).
//!
//! Storage is structure-of-arrays over all guides: link `l = g · n + i`, vertex
//! `g · (n + 1) + i`.

use nalgebra::{
    Matrix2, Matrix3, Matrix6, Matrix6x2, Quaternion, UnitQuaternion, Vector2, Vector3, Vector6,
};

/// The motion of the body a chain's root is fixed to (the head), in spatial coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Base {
    /// World rotation of the head.
    pub rot: Matrix3<f64>,
    /// Spatial velocity `(ω; v_O)`.
    pub vel: Vector6<f64>,
    /// Spatial acceleration minus gravity (Featherstone's trick: the base accelerates upwards
    /// by `-g` and no link needs a gravity force).
    pub acc: Vector6<f64>,
}

/// The joint-space state of every guide, and what forward kinematics derives from it.
#[derive(Debug, Clone, Default)]
pub struct Chains {
    /// Segments per guide.
    pub n: usize,
    /// Per guide: root position in the rest pose.
    pub root_rest: Vec<Vector3<f64>>,
    /// Per guide: whether the slot holds a simulated guide.
    pub alive: Vec<bool>,
    /// Per link: length, m.
    pub len: Vec<f64>,
    /// Per link: rest rotation from the parent frame (the head for link 0).
    pub r0: Vec<Matrix3<f64>>,
    /// Per link: joint rotation `J` (identity at rest; the child frame is `parent · R₀ · J`).
    pub q: Vec<UnitQuaternion<f64>>,
    /// Per link: joint rates, rad/s: the child's angular velocity relative to its parent, along
    /// the child's own `x` and `z` axes (perpendicular to the segment).
    pub qd: Vec<Vector2<f64>>,
    /// Per link: actuator spring, N·m/rad, and damping, N·m·s/rad.
    pub k: Vec<f64>,
    /// Per link: actuator damping.
    pub c: Vec<f64>,
    /// Per link: mass at its end vertex, kg, and rotational inertia about it, kg·m².
    pub m: Vec<f64>,
    /// Per link: rotational inertia about the end vertex.
    pub j: Vec<f64>,
    /// Per link (derived): world rotation.
    pub rot: Vec<Matrix3<f64>>,
    /// Per link (derived): spatial velocity.
    pub vs: Vec<Vector6<f64>>,
    /// Per vertex (derived): world position.
    pub x: Vec<Vector3<f64>>,
    /// Per vertex (derived): world velocity.
    pub v: Vec<Vector3<f64>>,
    /// Per vertex: external force on it this sub-step, N (the root's is ignored).
    pub f: Vec<Vector3<f64>>,
    /// Per vertex: the sum of the damping coefficients of the forces in `f`, N·s/m (air drag,
    /// link damping, contact damping and friction, each by the vertex's share).
    pub damp: Vec<f64>,
    /// Per vertex: the factor `1 / (1 + h C / m)` of backward Euler on the damping `C` of the
    /// vertex's forces (`m Δv = h (f − C Δv)`, `m` the mass of the vertex's link), from the
    /// previous sub-step's `damp`, and at most `m / (h C)` with this sub-step's `C`. Links and
    /// contacts scale their whole force by the smallest factor of their vertices, so action
    /// and reaction stay equal. Explicit, the damping of the tens of contacts of a vertex in
    /// dense short hair overshoots and feeds a whip.
    ///
    /// The cap is the rule that damping may bring a velocity to zero but never reverse it
    /// (Plante et al. §5.2, as DESIGN.md reads it): it binds only where a vertex's damping
    /// grows by more than `m / h` in one sub-step (a vertex meeting many contacts at once,
    /// `h C / m` above 10 for Short's 0.2 g vertices), and elsewhere the factor is the lagged
    /// one bit for bit. Without it that overshoot could grow: Short under `jump` with
    /// `body_margin: 0.0030003` went non-finite after 5 s (1 of 32 runs of Short and Short
    /// curly under `jump` and `stop` at margins moved by 1e-10 to 3e-7 m; with the cap, none).
    /// The factor from this sub-step's damping alone (no lag) cures that too, but the braid
    /// of `chang-fig6` then leaks (3 crossings): at a contact's onset its damping is then
    /// weaker than the lagged explicit one, which stops the approach in one step.
    pub soft: Vec<f64>,
    /// Largest joint rate reached by [`Chains::integrate`] since the last reset, rad/s (a
    /// diagnostic: nothing limits the rates).
    pub peak_rate: f64,
    scratch: Scratch,
    /// One scratch per run of [`Chains::runs`].
    run_scratch: Vec<Scratch>,
}

#[derive(Debug, Clone, Default)]
struct Scratch {
    s: Vec<Matrix6x2<f64>>,
    u: Vec<Matrix6x2<f64>>,
    dinv: Vec<Matrix2<f64>>,
    tau: Vec<Vector2<f64>>,
    c: Vec<Vector6<f64>>,
    ia: Vec<Matrix6<f64>>,
    pa: Vec<Vector6<f64>>,
}

impl Scratch {
    fn new(n: usize) -> Scratch {
        Scratch {
            s: vec![Matrix6x2::zeros(); n],
            u: vec![Matrix6x2::zeros(); n],
            dinv: vec![Matrix2::zeros(); n],
            tau: vec![Vector2::zeros(); n],
            c: vec![Vector6::zeros(); n],
            ia: vec![Matrix6::zeros(); n],
            pa: vec![Vector6::zeros(); n],
        }
    }
}

/// A run of consecutive guide slots of [`Chains`], borrowed for one thread: the guides' joint
/// state and what forward kinematics derives from it, mutable; their constants and this
/// sub-step's vertex forces, shared. Between the forces' gathering and the next one a guide
/// reads nothing of another guide, so runs advance on different threads with the same result,
/// bit for bit, as one after the other.
pub struct ChainRun<'a> {
    n: usize,
    /// The run's first slot: its link `l` is `first · n + l` of the chains, its vertex `v`
    /// is `first · (n + 1) + v`.
    first: usize,
    q: &'a mut [UnitQuaternion<f64>],
    qd: &'a mut [Vector2<f64>],
    rot: &'a mut [Matrix3<f64>],
    vs: &'a mut [Vector6<f64>],
    x: &'a mut [Vector3<f64>],
    v: &'a mut [Vector3<f64>],
    /// Per guide, per link and per vertex of all the chains (indexed like [`Chains`]).
    root_rest: &'a [Vector3<f64>],
    r0: &'a [Matrix3<f64>],
    len: &'a [f64],
    k: &'a [f64],
    c: &'a [f64],
    m: &'a [f64],
    j: &'a [f64],
    f: &'a [Vector3<f64>],
    scratch: &'a mut Scratch,
    /// The chains' [`Chains::peak_rate`], raised by this run's integration.
    pub peak_rate: f64,
}

/// `v` cut at the slot boundaries `ends` (in slots of `per` elements; non-decreasing, the last
/// at most the slots of `v`) into consecutive parts. An array: cutting allocates nothing.
fn cut<'a, T, const P: usize>(v: &'a mut [T], ends: &[usize; P], per: usize) -> [&'a mut [T]; P] {
    let mut rest = v;
    let mut taken = 0;
    std::array::from_fn(|c| {
        let e = ends[c] * per;
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(e - taken);
        rest = tail;
        taken = e;
        mine
    })
}

impl ChainRun<'_> {
    /// Forward kinematics of guide `g`: link rotations, vertex positions and velocities, link
    /// spatial velocities, from the joint state and the head. Linear in the chain length
    /// (§3.1: "the whole chain can be evaluated in linear time").
    #[inline(always)]
    pub fn fk(&mut self, g: usize, base: &Base, root: &Vector3<f64>) {
        let n = self.n;
        let (v0, l0) = self.local(g);
        self.x[v0] = *root;
        self.v[v0] = lin(&base.vel) + ang(&base.vel).cross(root);
        let mut parent = base.rot;
        let mut vp = base.vel;
        for i in 0..n {
            let (l, li) = (g * n + i, l0 + i);
            let cf = parent * self.r0[l] * self.q[li].to_rotation_matrix().into_inner();
            let u1 = cf.column(0).into_owned();
            let u2 = cf.column(2).into_owned();
            let p = self.x[v0 + i];
            let s1 = six(u1, p.cross(&u1));
            let s2 = six(u2, p.cross(&u2));
            let sq = s1 * self.qd[li].x + s2 * self.qd[li].y;
            let vs = vp + sq;
            let end = p + cf.column(1) * self.len[l];
            self.x[v0 + i + 1] = end;
            self.v[v0 + i + 1] = lin(&vs) + ang(&vs).cross(&end);
            self.rot[li] = cf;
            self.vs[li] = vs;
            let mut s = Matrix6x2::zeros();
            s.set_column(0, &s1);
            s.set_column(1, &s2);
            self.scratch.s[i] = s;
            // Ṡ q̇: both axes are fixed in the child, so Ṡ = v × S, and v × S q̇ = v_p × S q̇.
            self.scratch.c[i] = cross_motion(&vp, &sq);
            parent = cf;
            vp = vs;
        }
    }

    /// Joint accelerations of guide `g` by the articulated-body algorithm (three passes, linear
    /// time), then one semi-implicit Euler step of length `h`: the rates first, then each joint
    /// turned by `exp(h (ȧ, 0, ḃ))` about its current axes. Uses the kinematics of the last
    /// [`Chains::fk`] of this guide and its vertex forces `f`.
    #[inline(always)]
    pub fn integrate(&mut self, g: usize, base: &Base, h: f64) {
        let n = self.n;
        let (v0, l0) = self.local(g);
        let sc = &mut *self.scratch;
        for i in 0..n {
            let (l, li) = (g * n + i, l0 + i);
            let c = self.x[v0 + i + 1];
            sc.ia[i] = inertia(self.m[l], self.j[l], &c);
            let vs = self.vs[li];
            let fe = self.f[g * (n + 1) + i + 1];
            sc.pa[i] = cross_force(&vs, &(sc.ia[i] * vs)) - six(c.cross(&fe), fe);
            // The actuators are integrated implicitly (their torque at the end of the step):
            // τ = −k(θ + h q̇ + h² q̈) − c(q̇ + h q̈), θ the swing part of log J (the gradient of
            // ½ k |log J|² along the joint's two axes). The q̈ terms move into the joint-space
            // inertia below, so stiff actuators stay stable at any step.
            let th = log(&self.q[li]);
            let th = Vector2::new(th.x, th.z);
            sc.tau[i] = -(th + self.qd[li] * h) * self.k[l] - self.qd[li] * self.c[l];
        }
        for i in (0..n).rev() {
            let s = sc.s[i];
            let u = sc.ia[i] * s;
            let d = s.transpose() * u
                + Matrix2::identity() * (h * h * self.k[g * n + i] + h * self.c[g * n + i]);
            let dinv = d.try_inverse().unwrap_or_else(Matrix2::zeros);
            let uu = sc.tau[i] - s.transpose() * sc.pa[i];
            sc.u[i] = u;
            sc.dinv[i] = dinv;
            sc.tau[i] = uu;
            if i > 0 {
                let ia = sc.ia[i] - u * dinv * u.transpose();
                let pa = sc.pa[i] + ia * sc.c[i] + u * (dinv * uu);
                sc.ia[i - 1] += ia;
                sc.pa[i - 1] += pa;
            }
        }
        let mut a = base.acc;
        let mut peak = self.peak_rate;
        for i in 0..n {
            let li = l0 + i;
            let ap = a + sc.c[i];
            let qdd = sc.dinv[i] * (sc.tau[i] - sc.u[i].transpose() * ap);
            a = ap + sc.s[i] * qdd;
            self.qd[li] += qdd * h;
            let w = self.qd[li] * h;
            let mut q = self.q[li] * exp(&Vector3::new(w.x, 0.0, w.y));
            q.renormalize_fast();
            self.q[li] = q;
            peak = peak.max(self.qd[li].norm());
        }
        self.peak_rate = peak;
    }

    /// Puts guide `g` in the configuration of the points `pts` (`n + 1`, root first; only the
    /// segment directions are used, lengths stay the chain's) moving with the vertex velocities
    /// `vel`, for the head `base`. Needs the kinematics of the last [`Chains::fk`] of this guide
    /// with the same head: each link is turned from its current frame by the smallest rotation
    /// onto its new direction (so no twist is introduced and there is no singular pose), and
    /// each joint takes the rates that give its end vertex the velocity `vel` perpendicular to
    /// the segment (the component along it is fixed by the segment's length), root to tip.
    /// Call [`Chains::fk`] next.
    #[inline(always)]
    pub fn set_state(&mut self, g: usize, base: &Base, pts: &[Vector3<f64>], vel: &[Vector3<f64>]) {
        let n = self.n;
        let (v0, l0) = self.local(g);
        let mut parent = base.rot;
        let mut wp = ang(&base.vel);
        let mut vx = lin(&base.vel) + wp.cross(&self.x[v0]);
        for i in 0..n {
            let (l, li) = (g * n + i, l0 + i);
            let cur = self.rot[li];
            let dc = cur.column(1).into_owned();
            let d = (pts[i + 1] - pts[i]).try_normalize(1e-12).unwrap_or(dc);
            let child = min_rotation(&dc, &d) * cur;
            let jm = (parent * self.r0[l]).transpose() * child;
            let mut q = UnitQuaternion::from_rotation_matrix(
                &nalgebra::Rotation3::from_matrix_unchecked(jm),
            );
            q.renormalize();
            self.q[li] = q;
            let len = self.len[l];
            let dv = vel[i + 1] - vx;
            let w = d * wp.dot(&d) + d.cross(&dv) / len;
            let rel = w - wp;
            self.qd[li] = Vector2::new(child.column(0).dot(&rel), child.column(2).dot(&rel));
            vx += w.cross(&(d * len));
            parent = child;
            wp = w;
        }
    }

    /// Guide `g`'s first vertex and first link in this run's slices.
    fn local(&self, g: usize) -> (usize, usize) {
        let s = g - self.first;
        (s * (self.n + 1), s * self.n)
    }

    /// Largest joint rate of guide `g`, rad/s.
    pub fn max_rate(&self, g: usize) -> f64 {
        let (_, l0) = self.local(g);
        self.qd[l0..l0 + self.n]
            .iter()
            .map(|q| q.norm())
            .fold(0.0, f64::max)
    }

    /// Guide `g`'s rest root.
    pub fn root_rest(&self, g: usize) -> Vector3<f64> {
        self.root_rest[g]
    }

    /// Guide `g`'s link lengths.
    pub fn lengths(&self, g: usize) -> &[f64] {
        &self.len[g * self.n..(g + 1) * self.n]
    }

    /// Guide `g`'s vertex positions and velocities (root first).
    pub fn vertices(&self, g: usize) -> (&[Vector3<f64>], &[Vector3<f64>]) {
        let (v0, _) = self.local(g);
        let r = v0..v0 + self.n + 1;
        (&self.x[r.clone()], &self.v[r])
    }
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `log J` as a rotation vector (angle in [0, π]).
pub fn log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (w, v) = (q.w, q.imag());
    let (w, v) = if w < 0.0 { (-w, -v) } else { (w, v) };
    let s = v.norm();
    if s < 1e-12 {
        return v * 2.0;
    }
    v * (2.0 * s.atan2(w) / s)
}

/// `exp` of a rotation vector.
fn exp(r: &Vector3<f64>) -> UnitQuaternion<f64> {
    let t = r.norm();
    let half = 0.5 * t;
    let k = if t < 1e-8 { 0.5 } else { half.sin() / t };
    UnitQuaternion::new_unchecked(Quaternion::new(half.cos(), r.x * k, r.y * k, r.z * k))
}

fn ang(v: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

fn lin(v: &Vector6<f64>) -> Vector3<f64> {
    Vector3::new(v[3], v[4], v[5])
}

fn six(a: Vector3<f64>, l: Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, l.x, l.y, l.z)
}

/// `v ×` applied to a motion vector.
fn cross_motion(v: &Vector6<f64>, m: &Vector6<f64>) -> Vector6<f64> {
    let (w, vo) = (ang(v), lin(v));
    six(w.cross(&ang(m)), vo.cross(&ang(m)) + w.cross(&lin(m)))
}

/// `v ×*` applied to a force vector.
fn cross_force(v: &Vector6<f64>, f: &Vector6<f64>) -> Vector6<f64> {
    let (w, vo) = (ang(v), lin(v));
    six(w.cross(&ang(f)) + vo.cross(&lin(f)), w.cross(&lin(f)))
}

/// Spatial inertia at the origin of a point mass `m` at `c` with isotropic inertia `j` about it.
/// Always inlined, so that the guides' runs built for AVX2 compile it with them.
#[inline(always)]
fn inertia(m: f64, j: f64, c: &Vector3<f64>) -> Matrix6<f64> {
    let cx = skew(c);
    let mut out = Matrix6::zeros();
    let tl = Matrix3::identity() * j + cx * cx.transpose() * m;
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&tl);
    out.fixed_view_mut::<3, 3>(0, 3).copy_from(&(cx * m));
    out.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(cx.transpose() * m));
    out.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * m));
    out
}

/// The rotation taking unit `a` to unit `b` about `a × b` (identity if equal; a half turn
/// about a perpendicular axis if opposite).
pub fn min_rotation(a: &Vector3<f64>, b: &Vector3<f64>) -> Matrix3<f64> {
    // `I + [c]× + [c]×² / (1 + a·b)` with `c = a × b`: no `acos`, so nearly equal directions
    // (a dot product rounded above 1) give a rotation near the identity, never NaN.
    let c = a.cross(b);
    let d = a.dot(b);
    if 1.0 + d > 1e-9 {
        let k = skew(&c);
        return Matrix3::identity() + k + k * k / (1.0 + d);
    }
    let p = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::z()
    };
    let axis = nalgebra::Unit::new_normalize(a.cross(&p));
    *nalgebra::Rotation3::from_axis_angle(&axis, std::f64::consts::PI).matrix()
}

/// Wraps an angle difference into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = a.rem_euclid(t);
    if r > std::f64::consts::PI {
        r - t
    } else {
        r
    }
}

impl Chains {
    /// Empty storage for guides of `n` segments, with room for `capacity` guides.
    pub fn new(n: usize, capacity: usize) -> Chains {
        let links = n * capacity;
        let verts = (n + 1) * capacity;
        let mut c = Chains {
            n,
            ..Default::default()
        };
        c.root_rest.resize(capacity, Vector3::zeros());
        c.alive.resize(capacity, false);
        c.len.resize(links, 0.0);
        c.r0.resize(links, Matrix3::identity());
        c.q.resize(links, UnitQuaternion::identity());
        c.qd.resize(links, Vector2::zeros());
        c.k.resize(links, 0.0);
        c.c.resize(links, 0.0);
        c.m.resize(links, 0.0);
        c.j.resize(links, 0.0);
        c.rot.resize(links, Matrix3::identity());
        c.vs.resize(links, Vector6::zeros());
        c.x.resize(verts, Vector3::zeros());
        c.v.resize(verts, Vector3::zeros());
        c.f.resize(verts, Vector3::zeros());
        c.damp.resize(verts, 0.0);
        c.soft.resize(verts, 1.0);
        c.scratch = Scratch::new(n);
        c
    }

    /// Number of guide slots.
    pub fn capacity(&self) -> usize {
        self.alive.len()
    }

    /// Vertex range of guide `g`.
    pub fn verts(&self, g: usize) -> std::ops::Range<usize> {
        g * (self.n + 1)..(g + 1) * (self.n + 1)
    }

    /// Sets guide `g` up from its rest polyline (`n + 1` points in the rest pose, root first):
    /// rest rotations (parallel-transported frames, so the rest angles carry no twist), lengths,
    /// masses, and actuators scaled by the rest inertia of the chain beyond each joint. The
    /// guide starts at rest in the rest pose; call [`Chains::fk`] next.
    pub fn init_guide(
        &mut self,
        g: usize,
        rest: &[Vector3<f64>],
        mass: f64,
        stiffness: (f64, f64, f64),
    ) {
        let n = self.n;
        assert_eq!(rest.len(), n + 1, "a guide has n + 1 rest points");
        self.alive[g] = true;
        self.root_rest[g] = rest[0];
        let mut frame = Matrix3::identity();
        let (k, tip, damp) = stiffness;
        for i in 0..n {
            let l = g * n + i;
            let d = rest[i + 1] - rest[i];
            let len = d.norm().max(1e-6);
            let dir = d / len;
            let y = frame.column(1).into_owned();
            let next = min_rotation(&y, &dir) * frame;
            self.r0[l] = frame.transpose() * next;
            frame = next;
            self.len[l] = len;
            self.m[l] = mass / n as f64;
            self.j[l] = self.m[l] * (0.25 * len).powi(2);
            self.q[l] = UnitQuaternion::identity();
            self.qd[l] = Vector2::zeros();
        }
        for i in 0..n {
            let l = g * n + i;
            let inertia: f64 = (i..n)
                .map(|j| self.m[g * n + j] * (rest[j + 1] - rest[i]).norm_squared())
                .sum();
            let taper = 1.0 - (1.0 - tip) * i as f64 / (n.max(2) - 1) as f64;
            self.k[l] = k * inertia * taper;
            self.c[l] = damp * inertia * taper;
        }
    }

    /// Largest joint rate of guide `g`, rad/s.
    pub fn max_rate(&self, g: usize) -> f64 {
        let n = self.n;
        self.qd[g * n..(g + 1) * n]
            .iter()
            .map(|q| q.norm())
            .fold(0.0, f64::max)
    }

    /// Puts joint `l` at the rotation `exp((a, 0, b))` from its rest orientation: a swing by
    /// `|(a, b)|` rad about an axis perpendicular to the segment (for tests and set-ups).
    pub fn set_swing(&mut self, l: usize, swing: Vector2<f64>) {
        self.q[l] = exp(&Vector3::new(swing.x, 0.0, swing.y));
    }

    /// All slots as one run, with the chains' own scratch.
    fn whole(&mut self) -> ChainRun<'_> {
        ChainRun {
            n: self.n,
            first: 0,
            q: &mut self.q,
            qd: &mut self.qd,
            rot: &mut self.rot,
            vs: &mut self.vs,
            x: &mut self.x,
            v: &mut self.v,
            root_rest: &self.root_rest,
            r0: &self.r0,
            len: &self.len,
            k: &self.k,
            c: &self.c,
            m: &self.m,
            j: &self.j,
            f: &self.f,
            scratch: &mut self.scratch,
            peak_rate: self.peak_rate,
        }
    }

    /// The slots cut into `P` runs, run `c` ending before slot `ends[c]` (non-decreasing, the
    /// last the capacity), each with a scratch of its own, for as many threads. After them,
    /// fold each run's [`ChainRun::peak_rate`] into [`Chains::peak_rate`].
    pub fn runs<const P: usize>(&mut self, ends: &[usize; P]) -> [ChainRun<'_>; P] {
        let n = self.n;
        if self.run_scratch.len() < P {
            self.run_scratch.resize_with(P, || Scratch::new(n));
        }
        let mut q = cut(&mut self.q, ends, n).into_iter();
        let mut qd = cut(&mut self.qd, ends, n).into_iter();
        let mut rot = cut(&mut self.rot, ends, n).into_iter();
        let mut vs = cut(&mut self.vs, ends, n).into_iter();
        let mut x = cut(&mut self.x, ends, n + 1).into_iter();
        let mut v = cut(&mut self.v, ends, n + 1).into_iter();
        let mut scratch = self.run_scratch.iter_mut();
        let peak_rate = self.peak_rate;
        std::array::from_fn(|c| ChainRun {
            n,
            first: if c == 0 { 0 } else { ends[c - 1] },
            q: q.next().expect("P runs"),
            qd: qd.next().expect("P runs"),
            rot: rot.next().expect("P runs"),
            vs: vs.next().expect("P runs"),
            x: x.next().expect("P runs"),
            v: v.next().expect("P runs"),
            root_rest: &self.root_rest,
            r0: &self.r0,
            len: &self.len,
            k: &self.k,
            c: &self.c,
            m: &self.m,
            j: &self.j,
            f: &self.f,
            scratch: scratch.next().expect("a scratch per run"),
            peak_rate,
        })
    }

    /// [`ChainRun::fk`] of guide `g`.
    pub fn fk(&mut self, g: usize, base: &Base, root: &Vector3<f64>) {
        self.whole().fk(g, base, root);
    }

    /// [`ChainRun::integrate`] of guide `g`.
    pub fn integrate(&mut self, g: usize, base: &Base, h: f64) {
        let mut run = self.whole();
        run.integrate(g, base, h);
        let peak = run.peak_rate;
        self.peak_rate = peak;
    }

    /// [`ChainRun::set_state`] of guide `g`.
    pub fn set_state(&mut self, g: usize, base: &Base, pts: &[Vector3<f64>], vel: &[Vector3<f64>]) {
        self.whole().set_state(g, base, pts, vel);
    }

    /// Energy of guide `g` at its last forward kinematics: kinetic, gravitational (potential
    /// `−m g·x`) and actuator springs, J.
    pub fn energy(&self, g: usize, gravity: &Vector3<f64>) -> f64 {
        let n = self.n;
        let v0 = g * (n + 1);
        let mut e = 0.0;
        for i in 0..n {
            let l = g * n + i;
            let c = self.x[v0 + i + 1];
            let vs = self.vs[l];
            e += 0.5 * vs.dot(&(inertia(self.m[l], self.j[l], &c) * vs));
            e -= self.m[l] * gravity.dot(&c);
            e += 0.5 * self.k[l] * log(&self.q[l]).norm_squared();
        }
        e
    }
}
