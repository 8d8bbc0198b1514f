//! Guide strands as serial multibody chains in generalized coordinates (Chang, Jin, Yu 2002,
//! §3.1–3.2), integrated with Featherstone's articulated-body algorithm.
//!
//! Link `i` of a guide is the segment from vertex `i` to vertex `i + 1`; its joint sits at
//! vertex `i` and has two rotational degrees of freedom, no twist (§3.1: "twisting of a hair
//! strand along its axis is prohibited", two cascading 1-D revolute joints). The link frame has
//! its `y` axis along the segment; the child frame is
//! `parent · R₀ · Rx(a) · Rz(b)`, with `R₀` the rest rotation from the parent frame, so the
//! rest angles are zero and the actuators (§3.2: a hinge spring with damping towards the rest
//! angles) pull `(a, b)` back to 0. Positions come from the angles by forward kinematics, so
//! segment lengths are exact by construction.
//!
//! Spatial vectors are Plücker coordinates at the world origin, `(angular; linear)`; a link
//! lumps its mass at its end vertex with a small isotropic rotational inertia about it (the
//! cluster's thickness; it also keeps the joint-space inertia invertible).
//!
//! Storage is structure-of-arrays over all guides: link `l = g · n + i`, vertex
//! `g · (n + 1) + i`.

use nalgebra::{Matrix2, Matrix3, Matrix6, Matrix6x2, Vector2, Vector3, Vector6};

/// Default largest joint rate, rad/s (about 10 turns per second).
pub const MAX_RATE: f64 = 60.0;

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
    /// Per link: joint angles `(a, b)` and their rates.
    pub q: Vec<Vector2<f64>>,
    /// Per link: joint angle rates, rad/s.
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
    /// Largest joint rate, rad/s ([`MAX_RATE`] unless changed): a safety limit, see
    /// [`Chains::integrate`].
    pub max_rate: f64,
    scratch: Scratch,
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

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn rz(b: f64) -> Matrix3<f64> {
    let (s, c) = b.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
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
    match nalgebra::Rotation3::rotation_between(a, b) {
        Some(r) => *r.matrix(),
        None => {
            let p = if a.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::z()
            };
            let axis = nalgebra::Unit::new_normalize(a.cross(&p));
            *nalgebra::Rotation3::from_axis_angle(&axis, std::f64::consts::PI).matrix()
        }
    }
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
            max_rate: MAX_RATE,
            ..Default::default()
        };
        c.root_rest.resize(capacity, Vector3::zeros());
        c.alive.resize(capacity, false);
        c.len.resize(links, 0.0);
        c.r0.resize(links, Matrix3::identity());
        c.q.resize(links, Vector2::zeros());
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
        let sc = &mut c.scratch;
        sc.s.resize(n, Matrix6x2::zeros());
        sc.u.resize(n, Matrix6x2::zeros());
        sc.dinv.resize(n, Matrix2::zeros());
        sc.tau.resize(n, Vector2::zeros());
        sc.c.resize(n, Vector6::zeros());
        sc.ia.resize(n, Matrix6::zeros());
        sc.pa.resize(n, Vector6::zeros());
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
            self.q[l] = Vector2::zeros();
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

    /// Forward kinematics of guide `g`: link rotations, vertex positions and velocities, link
    /// spatial velocities, from the joint state and the head. Linear in the chain length
    /// (§3.1: "the whole chain can be evaluated in linear time").
    pub fn fk(&mut self, g: usize, base: &Base, root: &Vector3<f64>) {
        let n = self.n;
        let v0 = g * (n + 1);
        self.x[v0] = *root;
        self.v[v0] = lin(&base.vel) + ang(&base.vel).cross(root);
        let mut parent = base.rot;
        let mut vp = base.vel;
        for i in 0..n {
            let l = g * n + i;
            let (a, b) = (self.q[l].x, self.q[l].y);
            let ax = parent * self.r0[l];
            let u1 = ax.column(0).into_owned();
            let qf = ax * rx(a);
            let u2 = qf.column(2).into_owned();
            let cf = qf * rz(b);
            let p = self.x[v0 + i];
            let s1 = six(u1, p.cross(&u1));
            let s2 = six(u2, p.cross(&u2));
            let vs = vp + s1 * self.qd[l].x + s2 * self.qd[l].y;
            let end = p + cf.column(1) * self.len[l];
            self.x[v0 + i + 1] = end;
            self.v[v0 + i + 1] = lin(&vs) + ang(&vs).cross(&end);
            self.rot[l] = cf;
            self.vs[l] = vs;
            let mut s = Matrix6x2::zeros();
            s.set_column(0, &s1);
            s.set_column(1, &s2);
            self.scratch.s[i] = s;
            // Ṡ q̇: the first axis is fixed in the parent, the second in the child.
            self.scratch.c[i] =
                cross_motion(&vp, &s1) * self.qd[l].x + cross_motion(&vs, &s2) * self.qd[l].y;
            parent = cf;
            vp = vs;
        }
    }

    /// Joint accelerations of guide `g` by the articulated-body algorithm (three passes, linear
    /// time), then one semi-implicit Euler step of length `h`. Uses the kinematics of the last
    /// [`Chains::fk`] of this guide and its vertex forces `f`. Joint rates are limited to
    /// `max_rate`: with the few-segment guides and the explicit contact forces, a guide whipped
    /// by a fast head motion can otherwise gain energy without bound (a known limitation: the
    /// limit keeps the paper styles stable under every motion).
    pub fn integrate(&mut self, g: usize, base: &Base, h: f64) {
        let n = self.n;
        let v0 = g * (n + 1);
        let sc = &mut self.scratch;
        for i in 0..n {
            let l = g * n + i;
            let c = self.x[v0 + i + 1];
            sc.ia[i] = inertia(self.m[l], self.j[l], &c);
            let vs = self.vs[l];
            let fe = self.f[v0 + i + 1];
            sc.pa[i] = cross_force(&vs, &(sc.ia[i] * vs)) - six(c.cross(&fe), fe);
            // The actuators are integrated implicitly (their torque at the end of the step):
            // τ = −k(q + h q̇ + h² q̈) − c(q̇ + h q̈). The q̈ terms move into the joint-space
            // inertia below, so stiff actuators stay stable at any step.
            sc.tau[i] = -(self.q[l] + self.qd[l] * h) * self.k[l] - self.qd[l] * self.c[l];
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
        for i in 0..n {
            let l = g * n + i;
            let ap = a + sc.c[i];
            let qdd = sc.dinv[i] * (sc.tau[i] - sc.u[i].transpose() * ap);
            a = ap + sc.s[i] * qdd;
            self.qd[l] += qdd * h;
            // Safety limit on joint rates. Near b = ±π/2 the first axis lies along the segment
            // and only the small rotational inertia resists it, so a fast head motion can spin
            // a joint up; the rates of real hair stay far below this.
            let r = self.qd[l].norm();
            if r > self.max_rate {
                self.qd[l] *= self.max_rate / r;
            }
            self.q[l] += self.qd[l] * h;
        }
    }

    /// Joint angles of guide `g` that put its segments along `pts` (`n + 1` points, root
    /// first; only directions are used, lengths stay the chain's). The inverse of the forward
    /// kinematics for the twist-free parametrization: `b = −asin dₓ`, `a = atan2(d_z, d_y)` with
    /// `d` the segment direction in the frame `parent · R₀`, on the branch (and turn) nearest
    /// the chain's current angles.
    pub fn angles_from(
        &self,
        g: usize,
        rot: &Matrix3<f64>,
        pts: &[Vector3<f64>],
        out: &mut [Vector2<f64>],
    ) {
        let n = self.n;
        let mut parent = *rot;
        for i in 0..n {
            let l = g * n + i;
            let ax = parent * self.r0[l];
            let d = pts[i + 1] - pts[i];
            let d = ax.transpose() * (d / d.norm().max(1e-12));
            let b = (-d.x).clamp(-1.0, 1.0).asin();
            let a = d.z.atan2(d.y);
            // (a, b) and (a + π, π − b) give the same direction but frames half a turn apart:
            // keep the branch nearest the chain's current angles, so a correction never swaps
            // it (that would twist everything below by π).
            let cur = self.q[l];
            let near = |x: f64, r: f64| r + wrap(x - r);
            let p1 = Vector2::new(near(a, cur.x), near(b, cur.y));
            let p2 = Vector2::new(
                near(a + std::f64::consts::PI, cur.x),
                near(std::f64::consts::PI - b, cur.y),
            );
            let (a, b) = if (p2 - cur).norm_squared() < (p1 - cur).norm_squared() {
                (p2.x, p2.y)
            } else {
                (p1.x, p1.y)
            };
            out[i] = Vector2::new(a, b);
            parent = ax * rx(a) * rz(b);
        }
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
            e += 0.5 * self.k[l] * self.q[l].norm_squared();
        }
        e
    }
}
