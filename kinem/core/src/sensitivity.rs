//! Design sensitivities of a trajectory by direct differentiation of the
//! kinematic equations (docs/design.md, Eqs. S1-S3, S6): at each solved
//! instant (q, qd, qdd at t), for a design parameter p, with J = Phi_q,
//! s = dq/dp, sd = dqd/dp,
//!
//! ```text
//! J s   = -Phi_p                                   (S1)
//! J sd  = nu_p - A s - J_p qd                      (S2)
//! J sdd = D(gamma) - B s - J_p qdd                 (S3)
//! ```
//!
//! D(Phi_q) v = Phi_qq[s, v] + J_p v, and Phi_qq is symmetric in its two q
//! slots, so Phi_qq[s, v] = (D_v J) s = (D_s J) v (S6): the Jacobian's
//! tangent along q' = s and the tables' tangents, D(J) = D_s J + J_p, times
//! qd and qdd gives A s + J_p qd and B s + J_p qdd at once, without forming
//! A = D_qd(J) and B = D_qdd(J). Per group of parameters: Phi_p (Phi's
//! tangent at q' = 0, over the families the parameters move), s; then one
//! evaluation of the Jacobian at q' = s, nu_p (moved drivers), sd; then
//! D(gamma), gamma's tangent along q' = s, qd' = sd and the tables', sdd:
//! each over Lanes<N> (crate::real), N = 1, 2, 4 or 8 parameters at once
//! (`lanes`), each lane seeded with one parameter's tables' tangents
//! (Kin::seeded). All three share one factorisation of J at the instant
//! (the march's layout, crate::lu): no finite differences anywhere.
//!
//! A group of parameters alone (P <= 8) takes only what they reach
//! (`Reach`, `moving`): -Phi_p is zero outside the rows of the constraints
//! they move, so in the block-triangular order s, sd and sdd are zero at
//! every place the solve does not carry those rows to; the solves run
//! over the reached places, and the families and named points none of
//! whose coordinates is reached are skipped. A group that shifts the whole
//! mechanism along x or y (a ground's value) has s = that shift and
//! sd = sdd = 0 at every instant: its row is written once.
use crate::families::line::{slides_gamma, slides_products, Slide, SlideKept};
use crate::families::revolute::{phi_pins, pins_gamma, pins_products, PhiPin, Pin, PinKept};
use crate::families::{At, Dir, Family, Kept, Shared};
use crate::lu::{Factors, Layout, Shape};
use crate::model::Kin;
use crate::outline::Piece;
use crate::real::{cis, Lanes, Real};
use crate::table::Table;
use crate::triangular::{Cell, Program, DIV, NEGATE};
use num_complex::{Complex, Complex64 as C64};

/// How many parameters share one evaluation of the model and of the named
/// points' columns (crate::real::Lanes): as many as there are up to 8
/// (`lanes`: 1, 2, 4 or 8; an empty lane costs as a full one).
pub const LANES: [usize; 4] = [1, 2, 4, 8];

/// A design parameter's tangent of the model's tables: the families it
/// moves [(place among the model's families, the tangents of some of its
/// real and complex columns)], and the tangents of the functions' and the
/// outlines' tables (empty where it moves none).
pub struct Tangent {
    pub families: Vec<(usize, Table)>,
    pub functions: Table,
    pub outlines: Table,
}

/// The model over Lanes<N> with the tangents of `group` (at most N
/// parameters) in its lanes, a lane without a parameter zero.
fn seeded<const N: usize>(kin: &Kin, group: &[Tangent]) -> Result<Kin<Lanes<N>>, String> {
    let lanes = |tables: Vec<(usize, &Table)>| -> Table {
        let mut out = Table::default();
        for (lane, t) in tables {
            for (key, d) in &t.reals {
                let v = out.reals.entry(key.clone()).or_insert_with(|| vec![0.0; d.len() * N]);
                for (i, &x) in d.iter().enumerate() {
                    if let Some(o) = v.get_mut(i * N + lane) {
                        *o = x;
                    }
                }
            }
            for (key, d) in &t.complex {
                let v = out.complex.entry(key.clone()).or_insert_with(|| vec![C64::new(0.0, 0.0); d.len() * N]);
                for (i, &x) in d.iter().enumerate() {
                    if let Some(o) = v.get_mut(i * N + lane) {
                        *o = x;
                    }
                }
            }
        }
        out
    };
    let mut places: Vec<usize> = group.iter().flat_map(|t| t.families.iter().map(|f| f.0)).collect();
    places.sort_unstable();
    places.dedup();
    let families = places
        .iter()
        .map(|&k| {
            let of = group
                .iter()
                .enumerate()
                .flat_map(|(l, t)| t.families.iter().filter(|f| f.0 == k).map(move |f| (l, &f.1)));
            (k, lanes(of.collect()))
        })
        .collect::<Vec<_>>();
    let functions = lanes(group.iter().enumerate().map(|(l, t)| (l, &t.functions)).collect());
    let outlines = lanes(group.iter().enumerate().map(|(l, t)| (l, &t.outlines)).collect());
    kin.seeded(&families, &functions, &outlines)
}

/// x[0] (K, n): q at `times`; x[1], x[2]: qd, qdd (as many levels as
/// given); rows, cols: the Jacobian's pattern; columns: the trajectory's
/// column sources, the named points' body columns, local coordinates and
/// (P rows of) their tangents (crate::columns, checked by
/// crate::columns::check). Fills data (K, P W), row k the W columns'
/// tangents along the first parameter, then the second, ... (from dq/dp,
/// dqd/dp, dqdd/dp, over Lanes: crate::columns::Columns::row), and ratio
/// (K) with the pivot ratio of Phi_q (the caller flags singular instants).
/// Phi_q is evaluated and factorised here at every instant: the march's
/// own factorisation serves instead where it runs (`Instants::at` from
/// its hook, crate::march::run_hooked).
pub fn sensitivities(
    prepared: &Prepared,
    layout: &Layout,
    times: &[f64],
    x: &[&[f64]],
    data: &mut [f64],
    ratio: &mut [f64],
) -> Result<(), String> {
    let kin = &prepared.kin;
    let (n, kk, levels) = (kin.n, times.len(), x.len());
    if levels == 0 || levels > 3 || x.iter().any(|a| a.len() != kk * n) {
        return Err("sensitivity: 1 to 3 arrays of K x n coordinates expected".into());
    }
    let mut at = Instants::new(prepared, layout, levels)?;
    if data.len() != kk * at.width() || ratio.len() != kk {
        return Err("sensitivity: output arrays of the wrong size".into());
    }
    let mut f = layout.factors();
    let mut e = vec![C64::new(1.0, 0.0); n];
    let mut values = vec![0.0; kin.nnz];
    let w = at.width();
    for k in 0..kk {
        let (t, q) = (times[k], &x[0][k * n..(k + 1) * n]);
        kin.rotate(q, &mut e);
        kin.jac(&At { q, e: &e, t }, &mut values);
        layout.factor(&values, &mut f);
        let stages: [&[f64]; 3] = std::array::from_fn(|s| x.get(s).map_or(&[][..], |a| &a[k * n..(k + 1) * n]));
        ratio[k] = at.at(t, &stages[..levels], &e, &[], &mut f, 0.0, &mut data[k * w..(k + 1) * w]);
    }
    Ok(())
}

/// The sensitivities of one instant after another over the lanes that fit
/// the number of parameters (`lanes`): see `Lanewise`.
pub enum Instants<'a> {
    One(Lanewise<'a, 1>),
    Two(Lanewise<'a, 2>),
    Four(Lanewise<'a, 4>),
    Eight(Lanewise<'a, 8>),
}

macro_rules! each_width {
    ($self:expr, $x:ident => $e:expr) => {
        match $self {
            Instants::One($x) => $e,
            Instants::Two($x) => $e,
            Instants::Four($x) => $e,
            Instants::Eight($x) => $e,
        }
    };
}

/// The lanes for P parameters: the narrowest of LANES that holds them
/// all, else the widest (empty lanes cost as full ones).
pub fn lanes(p: usize) -> usize {
    LANES.iter().copied().find(|&w| w >= p).unwrap_or(LANES[LANES.len() - 1])
}

/// What the sensitivities of a model's parameters are set up from, made
/// once and kept (kinem.sensitivity keeps it per model and parameters:
/// Plan.sensitivity_setup): the model (every function and outline its own
/// number), the parameters' groups (`Group`: seeded models, moved and live
/// families, the products' entries: `probe`), the named points' local coordinates over the lanes and the
/// trajectory's column sources (`sensitivities`' columns).
pub struct Prepared {
    pub kin: Kin,
    np: usize,
    src: Vec<usize>,
    pc: Vec<usize>,
    points: usize,
    groups: Grouped,
    /// the Jacobian's pattern (row, column: `Reach`)
    pattern: Vec<(usize, usize)>,
}

/// The groups and the points' local coordinates over the lanes that fit
/// the number of parameters (`lanes`).
enum Grouped {
    One(Vec<Group<1>>, Vec<Vec<Complex<Lanes<1>>>>),
    Two(Vec<Group<2>>, Vec<Vec<Complex<Lanes<2>>>>),
    Four(Vec<Group<4>>, Vec<Vec<Complex<Lanes<4>>>>),
    Eight(Vec<Group<8>>, Vec<Vec<Complex<Lanes<8>>>>),
}

impl Prepared {
    /// From the model, the parameters' tangents, the Jacobian's pattern
    /// (rows, cols) and the columns (as `sensitivities`').
    pub fn new(kin: Kin, tangents: &[Tangent], rows: &[usize], cols: &[usize], columns: Cols) -> Result<Self, String> {
        let (src, pc, local, dlocal) = columns;
        let (n, m, nnz, np, points) = (kin.n, kin.m, kin.nnz, tangents.len(), local.len());
        if rows.len() != nnz || cols.len() != nnz || rows.iter().any(|&r| r >= m) || cols.iter().any(|&c| c >= n) {
            return Err("sensitivity: the Jacobian's pattern does not fit the model".into());
        }
        if dlocal.len() != np * points || pc.len() != points {
            return Err("sensitivity: output arrays of the wrong size".into());
        }
        let pattern: Vec<(usize, usize)> = rows.iter().copied().zip(cols.iter().copied()).collect();
        let (k, p) = (&kin, &pattern[..]);
        let groups = match lanes(np) {
            1 => Grouped::One(grouped(k, tangents, p)?, locals(tangents.len(), local, dlocal)),
            2 => Grouped::Two(grouped(k, tangents, p)?, locals(tangents.len(), local, dlocal)),
            4 => Grouped::Four(grouped(k, tangents, p)?, locals(tangents.len(), local, dlocal)),
            _ => Grouped::Eight(grouped(k, tangents, p)?, locals(tangents.len(), local, dlocal)),
        };
        Ok(Prepared { np, src: src.to_vec(), pc: pc.to_vec(), points, groups, kin, pattern })
    }

    /// The columns per instant and parameter (P W: an instant's row of data).
    pub fn width(&self) -> usize {
        self.np * self.src.len()
    }
}

/// The parameters' groups of N (Group::new).
fn grouped<const N: usize>(
    kin: &Kin,
    tangents: &[Tangent],
    pattern: &[(usize, usize)],
) -> Result<Vec<Group<N>>, String> {
    tangents.chunks(N).map(|g| Group::new(kin, g, pattern)).collect()
}

/// Per group of N parameters, the named points' local coordinates with
/// the group's tangents (dlocal, P rows of the points) in the lanes.
fn locals<const N: usize>(np: usize, local: &[C64], dlocal: &[C64]) -> Vec<Vec<Complex<Lanes<N>>>> {
    let points = local.len();
    (0..np.div_ceil(N))
        .map(|g| {
            (0..points)
                .map(|j| {
                    let (mut re, mut im) = ([0.0; N], [0.0; N]);
                    for p in g * N..(g * N + N).min(np) {
                        (re[p - g * N], im[p - g * N]) = (dlocal[p * points + j].re, dlocal[p * points + j].im);
                    }
                    Complex::new(Lanes::of(local[j].re, re), Lanes::of(local[j].im, im))
                })
                .collect()
        })
        .collect()
}

/// What a run of instants (`Instants`) owns beside the set-up and the
/// layout it reads: its scratch arrays, each group's reach (`Reach`, the
/// fixed rows with it) and the columns' layout, as `Lanewise::new` made
/// them for one set-up, layout and number of levels (`of`). A set-up keeps
/// the room its last run left (py/plan.rs, SensSetup), and the next run on
/// the same layout and levels enters it (`Instants::enter`) instead of
/// making it again (about 16 k instructions and 25 allocations a call on
/// the slider-crank). Each instant's pass writes before it reads every
/// place of the scratch but those it leaves as `new` made them (the places
/// a restricted solve does not reach stay zero, e^{i q}'s entries at no
/// angle stay 1 and 0), so a run in a kept room is a run in a fresh one,
/// to the bit, as each instant of one run is after the one before.
pub struct Room {
    /// the set-up's and the layout's addresses, and the levels
    of: (usize, usize, usize),
    lanes: Rooms,
}

enum Rooms {
    One(LaneRoom<1>),
    Two(LaneRoom<2>),
    Four(LaneRoom<4>),
    Eight(LaneRoom<8>),
}

/// `Lanewise`'s own fields (its buffers and figures made from the set-up),
/// held by a run as one value (`Lanewise::room`) and moved out whole by
/// `Lanewise::leave`. `levels`: the stages (1 to 3); `turned`: every named
/// point's body angle an angle column (its e^{i phi} is the march's e, no
/// sine and cosine taken again); `lanes0`: whether any group has a moved
/// family without direct kernels (its Phi_p over the lanes at q0, e0);
/// `flat`: s, sd, sdd (n each) and the points' tangents, a row per
/// coordinate or point value; `gather`: each column's row there;
/// `triples`: the columns (c, its row i) whose next two columns are rows
/// i + 1, i + 2 (a body's x, y, phi at one level), `singles` the others
/// (N = 1's gather: three columns per copy); `kv`, `kd`: what the direct
/// families' jac_products keep for their gamma_tangent; `reach`: per
/// group, what its parameters reach (`Reach`).
struct LaneRoom<const N: usize> {
    np: usize,
    levels: usize,
    w: usize,
    turned: bool,
    lanes0: bool,
    flat: Vec<[f64; N]>,
    gather: Vec<usize>,
    triples: Vec<(usize, usize)>,
    singles: Vec<(usize, usize)>,
    buf: Vec<[f64; N]>,
    q0: Vec<Lanes<N>>,
    e0: Vec<Complex<Lanes<N>>>,
    ql: Vec<Lanes<N>>,
    qdl: Vec<Lanes<N>>,
    el: Vec<Complex<Lanes<N>>>,
    rl: Vec<Lanes<N>>,
    jl: Vec<Lanes<N>>,
    rhs: Vec<[f64; N]>,
    rhs3: Vec<[f64; N]>,
    kv: Vec<C64>,
    kd: Vec<[f64; N]>,
    solver: Solver<N>,
    reach: Vec<Reach<N>>,
    /// what the lists' (S2) kernels keep for their (S3) kernels (`Lists`)
    pk: Vec<PinKept<N>>,
    sk: Vec<SlideKept<N>>,
}

impl<'a> Instants<'a> {
    /// A run of instants with `levels` stages (1 to 3) from the kept
    /// set-up and the march's layout (`Lanewise::new`).
    pub fn new(prepared: &'a Prepared, layout: &'a Layout, levels: usize) -> Result<Self, String> {
        Self::enter(prepared, layout, levels, None)
    }

    /// `new`, in `room` where a run of the same set-up on the same layout
    /// and levels left it (`leave`; a room of another run is dropped).
    pub fn enter(
        prepared: &'a Prepared,
        layout: &'a Layout,
        levels: usize,
        room: Option<Room>,
    ) -> Result<Self, String> {
        if levels == 0 || levels > 3 {
            return Err("sensitivity: 1 to 3 levels expected".into());
        }
        let p = prepared;
        crate::columns::check(p.kin.n, levels, &p.src, &p.pc, p.points)?;
        let of = (p as *const Prepared as usize, layout as *const Layout as usize, levels);
        let room = room.filter(|r| r.of == of).map(|r| r.lanes);
        Ok(match (&p.groups, room) {
            (Grouped::One(g, l), Some(Rooms::One(r))) => Instants::One(Lanewise::enter(p, g, l, layout, r)),
            (Grouped::Two(g, l), Some(Rooms::Two(r))) => Instants::Two(Lanewise::enter(p, g, l, layout, r)),
            (Grouped::Four(g, l), Some(Rooms::Four(r))) => Instants::Four(Lanewise::enter(p, g, l, layout, r)),
            (Grouped::Eight(g, l), Some(Rooms::Eight(r))) => Instants::Eight(Lanewise::enter(p, g, l, layout, r)),
            (Grouped::One(g, l), _) => Instants::One(Lanewise::new(p, g, l, layout, levels)),
            (Grouped::Two(g, l), _) => Instants::Two(Lanewise::new(p, g, l, layout, levels)),
            (Grouped::Four(g, l), _) => Instants::Four(Lanewise::new(p, g, l, layout, levels)),
            (Grouped::Eight(g, l), _) => Instants::Eight(Lanewise::new(p, g, l, layout, levels)),
        })
    }

    /// The run's room, for the next run of the same set-up (`enter`).
    pub fn leave(self, prepared: &Prepared, layout: &Layout) -> Room {
        let lanes = match self {
            Instants::One(a) => Rooms::One(a.leave()),
            Instants::Two(a) => Rooms::Two(a.leave()),
            Instants::Four(a) => Rooms::Four(a.leave()),
            Instants::Eight(a) => Rooms::Eight(a.leave()),
        };
        let levels = match &lanes {
            Rooms::One(r) => r.levels,
            Rooms::Two(r) => r.levels,
            Rooms::Four(r) => r.levels,
            Rooms::Eight(r) => r.levels,
        };
        let of = (prepared as *const Prepared as usize, layout as *const Layout as usize, levels);
        Room { of, lanes }
    }

    /// The columns per instant and parameter (P W: an instant's row of data).
    pub fn width(&self) -> usize {
        each_width!(self, x => x.width())
    }

    /// Lanewise::at.
    #[allow(clippy::too_many_arguments)]
    pub fn at(
        &mut self,
        t: f64,
        x: &[&[f64]],
        e: &[C64],
        pieces: &[Piece],
        f: &mut Factors,
        pivot: f64,
        out: &mut [f64],
    ) -> f64 {
        each_width!(self, a => a.at(t, x, e, pieces, f, pivot, out))
    }
}

/// Up to N parameters' model (Kin::seeded, a lane each) and the families
/// their tables move: only those rows carry Phi_p and nu_p.
struct Group<const N: usize> {
    model: Kin<Lanes<N>>,
    count: usize,
    /// of the moved families (where a function's or an outline's table
    /// moves, every family that reads it: `reads`), those whose nu may be non-zero (none where no function
    /// but a constant moves: a constant's derivatives are zero)
    timed: Vec<usize>,
    /// whether a function that is not a constant moves (Dir::drives)
    drives: bool,
    /// the families whose Jacobian and gamma have a tangent: the moved and
    /// those that depend on q or qd; the others' are zero. `direct`: those
    /// with the direct tangent kernels (Family::direct: over the march's
    /// values, no lanes), with whether each is moved; `live`: the others,
    /// evaluated over the lanes
    direct: Vec<Direct>,
    live: Vec<usize>,
    /// (S1)'s kernels: the moved revolute families' joints in one list
    /// (`PhiPin`), and the other moved families, each with its place in
    /// `direct` where its phi_tangent keeps what its jac_products reads
    /// (Family::hands, Direct's `held`)
    phi_pins: Vec<PhiPin<N>>,
    phi_rest: Vec<(usize, Option<usize>)>,
    /// the moved families without direct kernels (Phi_p over the lanes)
    moved_lanes: bool,
    /// the Jacobian's entries (row, column, place) of the `live` families
    /// whose tangent may be non-zero (`entries`): the (S2), (S3) products
    /// over the lanes read these alone
    entries: Vec<(usize, usize, usize)>,
    /// how many values and tangents the direct families keep (`Direct`)
    kept: (usize, usize),
    /// the rows whose Phi_p may be non-zero, and the group's shift where
    /// s is one at every instant (`moving`)
    seeds: Vec<bool>,
    shift: Option<Vec<[f64; N]>>,
}

impl<const N: usize> Group<N> {
    fn new(kin: &Kin, group: &[Tangent], pattern: &[(usize, usize)]) -> Result<Self, String> {
        let model = seeded::<N>(kin, group)?;
        let empty = |t: &Table| t.reals.is_empty() && t.complex.is_empty();
        let (functions, outlines) =
            (group.iter().any(|t| !empty(&t.functions)), group.iter().any(|t| !empty(&t.outlines)));
        let mut moved: Vec<usize> = group.iter().flat_map(|t| t.families.iter().map(|f| f.0)).collect();
        moved.extend((0..kin.families.len()).filter(|&k| {
            let (f, o) = kin.families[k].reads();
            (functions && f) || (outlines && o)
        }));
        moved.sort_unstable();
        moved.dedup();
        // nu (f'(t), 2 l l') moves only with a function that is not a constant
        let fs = &model.functions;
        let drives = (0..fs.len()).any(|f| !fs.constant(f) && fs.moves(f));
        let timed = moved.iter().copied().filter(|k| drives && model.time_dependent.contains(k)).collect();
        // (and f'' likewise: Dir::drives)
        let (live, mut entries) = probe(&model, &moved, pattern);
        let (direct, live): (Vec<usize>, Vec<usize>) = live.into_iter().partition(|&k| kin.families[k].direct());
        entries.retain(|&(_, _, p)| live.iter().any(|&k| (model.entry_off[k]..model.entry_off[k + 1]).contains(&p)));
        let (mut v, mut d) = (0, 0);
        let direct: Vec<Direct> = direct
            .into_iter()
            .map(|k| {
                let (vn, dn) = model.families[k].kept();
                (v, d) = (v + vn, d + dn);
                let rows = model.row_off[k]..model.row_off[k + 1];
                let moved = moved.contains(&k);
                let held = moved && model.families[k].hands();
                Direct { k, rows, moved, held, v: v - vn..v, d: d - dn..d }
            })
            .collect();
        let hands: Vec<Option<usize>> = moved.iter().map(|&k| direct.iter().position(|f| f.k == k && f.held)).collect();
        let moved_lanes = moved.iter().any(|&k| !kin.families[k].direct());
        let (mut phi_pins, mut phi_rest) = (Vec::new(), Vec::new());
        for (&k, &hand) in moved.iter().zip(&hands) {
            match &model.families[k] {
                Family::Revolute(r) => phi_pins.extend(r.phi_pins(model.row_off[k])),
                _ => phi_rest.push((k, hand)),
            }
        }
        let (seeds, shift) = moving(&model, &moved, drives || outlines, group.len());
        let count = group.len();
        Ok(Group {
            model,
            count,
            timed,
            drives,
            direct,
            live,
            phi_pins,
            phi_rest,
            moved_lanes,
            entries,
            kept: (v, d),
            seeds,
            shift,
        })
    }
}

/// A family with the direct tangent kernels in a group: its place, its
/// rows, whether it is moved, and where its jac_products keeps its values
/// (v) and tangents (d) for its gamma_tangent (Family::kept, Lanewise's kv,
/// kd); `held`: moved, and its phi_tangent keeps them there first for its
/// jac_products (Family::hands).
struct Direct {
    k: usize,
    rows: std::ops::Range<usize>,
    moved: bool,
    held: bool,
    v: std::ops::Range<usize>,
    d: std::ops::Range<usize>,
}

/// The probe of a group (its seeded model, `moved` its moved families):
/// the Jacobian and gamma at two generic points (q, q', qd, qd' in every
/// lane, t) with the group's tables' tangents. Returns the live families
/// and the Jacobian entries whose tangent may be non-zero.
///
/// A family is live if it is moved, or of a kind that may hold no fixed
/// rows (Family::may_be_fixed: all but simple and gear), or its Jacobian's
/// or gamma's tangent is not exactly zero at a probe point: those kinds'
/// kernels are polynomial in e^{i q}, q, qd and their tables, so a term
/// that reads q or qd carries a non-zero tangent at a generic point and
/// one that does not carries none (a ground's or a driver's rows, a gear's
/// Jacobian); a family that is not live has D(J) = 0 and D(gamma) = 0.
///
/// Of the live families, an entry whose tangent is zero at both points is
/// zero everywhere (its kernel does not read q or a moved table: a joint's
/// constant blocks) and the products skip it (subtracting 0 a changes no
/// sum), except in the kinds whose outlines are piecewise (the curves and
/// cams, Family::piecewise: every entry of theirs is kept).
fn probe<const N: usize>(
    model: &Kin<Lanes<N>>,
    moved: &[usize],
    pattern: &[(usize, usize)],
) -> (Vec<usize>, Vec<(usize, usize, usize)>) {
    let n = model.n;
    let shared = Shared { functions: &model.functions, outlines: &model.outlines };
    let (mut seen, mut live) = (vec![false; model.nnz], vec![false; model.families.len()]);
    let (mut j, mut g) = (vec![Lanes::<N>::c(0.0); model.nnz], vec![Lanes::<N>::c(0.0); model.m]);
    let mut e = vec![Complex::new(Lanes::c(1.0), Lanes::c(0.0)); n];
    for (a, t) in [(0.3, 0.37), (1.1, 1.9)] {
        let lanes = |v: f64, d: f64, step: f64| -> Vec<Lanes<N>> {
            (0..n)
                .map(|c| Lanes::of(a + v * c as f64, std::array::from_fn(|l| d + step * c as f64 - 0.13 * l as f64)))
                .collect()
        };
        let (q, qd) = (lanes(0.7, 1.0, 0.1), lanes(0.2, 0.9, -0.05));
        model.rotate(&q, &mut e);
        let at = At { q: &q, e: &e, t };
        for (k, family) in model.families.iter().enumerate() {
            let (place, rows) = (model.entry_off[k]..model.entry_off[k + 1], model.row_off[k]..model.row_off[k + 1]);
            family.jac(&at, &shared, &mut j[place.clone()]);
            family.gamma(&at, &qd, &shared, &mut g[rows.clone()]);
            let moves = |x: &Lanes<N>| x.d.iter().any(|&v| v != 0.0);
            live[k] |=
                moved.contains(&k) || !family.may_be_fixed() || j[place.clone()].iter().chain(&g[rows]).any(moves);
            for p in place {
                seen[p] |= family.piecewise() || moves(&j[p]);
            }
        }
    }
    let live: Vec<usize> = (0..model.families.len()).filter(|&k| live[k]).collect();
    let entries = live
        .iter()
        .flat_map(|&k| model.entry_off[k]..model.entry_off[k + 1])
        .filter(|&p| seen[p])
        .map(|p| (pattern[p].0, pattern[p].1, p))
        .collect();
    (live, entries)
}

/// The rows of a group (its seeded model, `moved` its moved families,
/// `tables`: whether an outline's table or a function that is not a
/// constant moves (a constant's Phi_p is too: no pieces in t), `count`
/// its parameters) whose Phi_p may be non-zero, and the group's shift: s
/// per coordinate where every parameter of the group moves the mechanism
/// rigidly along x or y, or moves nothing (None where one does not).
///
/// At two generic points (q, t) Phi's tangent is taken along q' = 0 with
/// the tables' tangents (Phi_p), and along q' = X and q' = Y (every body's
/// x, y coordinate moved by 1) with them. Phi is polynomial in e^{i q}, q
/// and its tables but for the functions' and outlines' pieces, so (as in
/// `probe`) a row whose Phi_p is zero at both points is zero everywhere;
/// every row of a moved family that reads a moved function's or outline's
/// table, or reads an outline at all (Family::piecewise), is taken as
/// well. A parameter whose tangent along q' = T is zero in every row at
/// both points (and that moves no function or outline) has
/// Phi_q T + Phi_p = 0 at every q and t: s = T (Eq. S1) at every instant,
/// and, that identity's q and t derivatives being zero too, the
/// right-hand sides of (S2) and (S3) are zero: sd = sdd = 0.
fn moving<const N: usize>(
    model: &Kin<Lanes<N>>,
    moved: &[usize],
    tables: bool,
    count: usize,
) -> (Vec<bool>, Option<Vec<[f64; N]>>) {
    let (n, m, angles) = (model.n, model.m, &model.angles);
    // a body's x column: its angle column less 2, where neither column between is an angle (an
    // outline's angle follows another angle column)
    let x: Vec<usize> = angles
        .iter()
        .filter(|&&a| a >= 2 && !angles.contains(&(a - 1)) && !angles.contains(&(a - 2)))
        .map(|&a| a - 2)
        .collect();
    let shifts: [Vec<f64>; 3] = std::array::from_fn(|k| {
        let mut t = vec![0.0; n];
        for &c in &x {
            if k > 0 {
                t[c + k - 1] = 1.0;
            }
        }
        t
    });
    let mut seeds = vec![false; m];
    let mut fits = [[true; N]; 3];
    let (mut out, mut e) = (vec![Lanes::<N>::c(0.0); m], vec![Complex::new(Lanes::c(1.0), Lanes::c(0.0)); n]);
    for (a, t) in [(0.3, 0.37), (1.1, 1.9)] {
        // shifts[0]: q' = 0, the tangent along the tables alone (Phi_p)
        for (k, (shift, fit)) in shifts.iter().zip(&mut fits).enumerate() {
            let q: Vec<Lanes<N>> = (0..n).map(|c| Lanes::of(a + 0.7 * c as f64, [shift[c]; N])).collect();
            model.rotate(&q, &mut e);
            model.phi(&At { q: &q, e: &e, t }, &mut out);
            for (r, v) in out.iter().enumerate() {
                for l in 0..N {
                    if v.d[l] != 0.0 {
                        fit[l] = false;
                    }
                }
                seeds[r] |= k == 0 && v.d.iter().any(|&x| x != 0.0);
            }
        }
    }
    for &k in moved {
        let f = &model.families[k];
        if f.piecewise() || (tables && (f.reads().0 || f.reads().1)) {
            seeds[model.row_off[k]..model.row_off[k + 1]].fill(true);
        }
    }
    let shift = (!tables && (0..count).all(|l| fits.iter().any(|f| f[l]))).then(|| {
        (0..n)
            .map(|c| {
                std::array::from_fn(|l| match (0..3).find(|&k| fits[k][l]) {
                    Some(k) if l < count => shifts[k][c],
                    _ => 0.0,
                })
            })
            .collect()
    });
    (seeds, shift)
}

/// What a group's parameters reach in a run of instants (issue 30; taken
/// where `partial`, for a group alone, else every place): the
/// places of the block-triangular solve that (S1)-(S3) can make non-zero,
/// from the rows whose Phi_p may be non-zero (`moving`) and the rows whose
/// constraints read a reached coordinate (their D(J), D(gamma)), to a
/// fixed point; the coordinates not reached have s = sd = sdd = 0 exactly.
/// `program`: the solve restricted to them (Program::reached, resolved
/// once: `Restricted`; None: every place reached, or a layout without the
/// blocks' order), `rows` the rows reached (row, place), which its run
/// copies or reads, `zero` the places a full solve (the
/// fallback's, the inverse's) leaves to be zeroed; `direct`: the direct
/// families of the group (their places in its `direct`) whose (S2), (S3)
/// kernels run (the others' rows' right sides are zero) and are not in
/// `lists`; `points`: the named points taken (on
/// a reached body, or their local coordinates moved); `fixed`: the
/// group's whole output where its shift is known (`moving`) and no named
/// point's local coordinates move. `lists`: the revolute and line
/// families' constraints whose (S2), (S3) kernels run, as one list per
/// kind (`Lists`; their families not in `direct`), those with a row where
/// the parameters reach (`from`: the others' right sides are zero) or all.
struct Reach<const N: usize> {
    program: Option<Restricted>,
    rows: Vec<(u32, u32)>,
    zero: Vec<u32>,
    direct: Vec<usize>,
    points: Vec<usize>,
    fixed: Option<Vec<f64>>,
    lists: Lists<N>,
}

/// The revolute joints (`Pin`) and the point-on-line constraints (`Slide`)
/// of a group whose kernels run, in one list per kind over every family
/// of it: the first `pins_moved` joints read no table tangent, the rest
/// do (`Pin::moving`); the first `slides_moved` constraints are of
/// unmoved families, the rest of moved ones.
struct Lists<const N: usize> {
    pins: Vec<Pin<N>>,
    pins_moved: usize,
    slides: Vec<Slide<N>>,
    slides_moved: usize,
}

impl<const N: usize> Lists<N> {
    /// The lists of the group's direct families that run (`direct`, set
    /// false for those taken here), each constraint of them with
    /// `take(row)` true for one of its rows.
    /// `quiet(c)`: column c's place is one no restricted solve reaches
    /// (its s, sd +0 at every instant: a joint's side there is left out,
    /// `Pin::lone`).
    fn new(group: &Group<N>, direct: &mut [bool], take: impl Fn(usize) -> bool, quiet: impl Fn(usize) -> bool) -> Self {
        let (mut pins, mut moving, mut slides, mut moved) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (f, run) in group.direct.iter().zip(direct.iter_mut()).filter(|x| *x.1) {
            let row0 = f.rows.start;
            match &group.model.families[f.k] {
                Family::Revolute(r) => {
                    for p in r.pins(row0, f.moved, |c| take(row0 + 2 * c) || take(row0 + 2 * c + 1)) {
                        let p = p.lone(&quiet);
                        if p.moving() {
                            moving.push(p);
                        } else {
                            pins.push(p);
                        }
                    }
                }
                Family::Line(l) => {
                    let per = l.per();
                    let taken = l.slides(row0, |c| (0..per).any(|i| take(row0 + per * c + i)));
                    if f.moved {
                        moved.extend(taken);
                    } else {
                        slides.extend(taken);
                    }
                }
                _ => continue,
            }
            *run = false;
        }
        let (pins_moved, slides_moved) = (pins.len(), slides.len());
        pins.extend(moving);
        slides.extend(moved);
        Lists { pins, pins_moved, slides, slides_moved }
    }
}

impl<const N: usize> Reach<N> {
    fn new(p: &Prepared, group: &Group<N>, locs: &[Complex<Lanes<N>>], layout: &Layout, partial: bool) -> Self {
        let (n, m, points) = (p.kin.n, p.kin.m, p.points);
        let local = |j: usize| locs[j].re.d.iter().chain(&locs[j].im.d).any(|&x| x != 0.0);
        let all = || {
            let mut direct = vec![true; group.direct.len()];
            let lists = Lists::new(group, &mut direct, |_| true, |_| false);
            let direct = (0..direct.len()).filter(|&i| direct[i]).collect();
            Reach {
                program: None,
                rows: Vec::new(),
                zero: Vec::new(),
                direct,
                points: (0..points).collect(),
                fixed: None,
                lists,
            }
        };
        let t = match &layout.shape {
            Shape::Triangular(t) if partial && t.into.len() == m && m == n && t.program.positions == n => t,
            _ => return all(),
        };
        let place = |r: usize| t.into[r] as usize;
        let mut from = vec![false; n];
        (0..m).filter(|&r| group.seeds[r]).for_each(|r| from[place(r)] = true);
        let (reached, program) = loop {
            let (reached, program) = t.program.reached(&from);
            let mut more = from.clone();
            p.pattern.iter().filter(|&&(_, c)| reached[c]).for_each(|&(r, _)| more[place(r)] = true);
            if more == from {
                break (reached, program);
            }
            from = more;
        };
        if reached.iter().all(|&r| r) {
            return all();
        }
        // (a constraint none of whose rows is in `from` has no seed and reads no reached coordinate: its
        // kernels add zeros of either sign to its rows' +0, which stay +0, as a family's left out)
        let mut direct: Vec<bool> = group.direct.iter().map(|f| f.rows.clone().any(|r| from[place(r)])).collect();
        let lists = Lists::new(group, &mut direct, |r| from[place(r)], |c| !reached[c]);
        let direct = (0..direct.len()).filter(|&i| direct[i]).collect();
        let rows: Vec<(u32, u32)> =
            (0..m).filter(|&r| reached[place(r)]).map(|r| (r as u32, place(r) as u32)).collect();
        Reach {
            program: Some(Restricted::new(&program, &rows)),
            rows,
            zero: (0..n).filter(|&c| !reached[c]).map(|c| c as u32).collect(),
            direct,
            points: (0..points).filter(|&j| local(j) || (0..3).any(|i| reached[p.pc[j] + i])).collect(),
            fixed: None,
            lists,
        }
    }
}

/// A restricted program (`Program::reached`) resolved once per set-up
/// (issue 30 round 18): the rows reached copied to their places
/// (`copies`, (row, place)), then its operations one after the other in
/// the same order (`ops`, `[i, c, u]`: w[i] -= a[u] w[c], or where c is
/// DIV w[i] *= a[u], u without NEGATE's bit: Program::run multiplies by
/// the value under it), each reading and writing its place, with no runs
/// to decode (the few places a parameter reaches make runs of one or two
/// operations). `run` gives the rows' copy and `Program::run`'s figures,
/// to the bit. Where the program has quiet positions (`quiet`: their
/// rows), `short` is its short program resolved the same way, run where
/// all of their rows are zero (as `Program::run` does).
struct Restricted {
    copies: Vec<(u32, u32)>,
    quiet: Vec<u32>,
    ops: Vec<[u32; 3]>,
    short: Vec<[u32; 3]>,
    /// the largest place + 1, row + 1 and factor index + 1 read (`run` asserts its slices that long)
    bounds: (usize, usize, usize),
}

impl Restricted {
    /// `program` (Program::reached) over the reached places' rows `rows`
    /// ((row, place), every reached place's), resolved.
    fn new(program: &Program, rows: &[(u32, u32)]) -> Self {
        let resolve = |short: bool| -> Vec<[u32; 3]> {
            let ops = program.operations(short);
            ops.into_iter().map(|[i, c, u]| if c == DIV { [i, c, u & !NEGATE] } else { [i, c, u] }).collect()
        };
        let quiet: Vec<u32> = (program.quiet.iter())
            .map(|&q| rows.iter().find(|x| x.1 == q).expect("a quiet place reached has its row").0)
            .collect();
        let (ops, short) = (resolve(false), if quiet.is_empty() { Vec::new() } else { resolve(true) });
        let (mut places, mut rows_read, mut values) = (0, 0, 0);
        for &(r, c) in rows {
            (rows_read, places) = (rows_read.max(r as usize + 1), places.max(c as usize + 1));
        }
        for &[i, c, u] in ops.iter().chain(&short) {
            places = places.max(i as usize + 1);
            places = if c != DIV { places.max(c as usize + 1) } else { places };
            values = values.max(u as usize + 1);
        }
        rows_read = quiet.iter().fold(rows_read, |x, &r| x.max(r as usize + 1));
        Restricted { copies: rows.to_vec(), quiet, ops, short, bounds: (places, rows_read, values) }
    }

    /// The rows' copy and the restricted program's run (w: the places, rhs
    /// the right side's rows, a the factors): `Program::run`'s figures
    /// after the rows reached are copied to their places, to the bit.
    #[cfg(test)]
    fn run<const N: usize>(&self, a: &[f64], rhs: &[[f64; N]], w: &mut [[f64; N]]) {
        let (places, rows, values) = self.bounds;
        assert!(w.len() >= places && rhs.len() >= rows && a.len() >= values);
        // SAFETY: every place, row and factor index read below `bounds` (Restricted::new), asserted above
        unsafe { self.run_unchecked(a, rhs, w) }
    }

    /// `run` without its checks (`Lanewise::at` makes them once an instant).
    ///
    /// # Safety
    /// w, rhs and a at least as long as `bounds`.
    #[inline(always)]
    unsafe fn run_unchecked<const N: usize>(&self, a: &[f64], rhs: &[[f64; N]], w: &mut [[f64; N]]) {
        unsafe {
            for &(r, c) in &self.copies {
                *w.get_unchecked_mut(c as usize) = *rhs.get_unchecked(r as usize);
            }
            let quiet = !self.quiet.is_empty() && self.quiet.iter().all(|&r| rhs.get_unchecked(r as usize).zero());
            for &[i, c, u] in if quiet { &self.short } else { &self.ops } {
                let mut y = *w.get_unchecked(i as usize);
                if c != DIV {
                    y.sub_mul(*a.get_unchecked(u as usize), *w.get_unchecked(c as usize));
                } else {
                    y.mul(*a.get_unchecked(u as usize));
                }
                *w.get_unchecked_mut(i as usize) = y;
            }
        }
    }
}

/// The sensitivities of one instant after another, N parameters per
/// evaluation (Eqs. S1-S3), from the factorisation of Phi_q at each
/// instant's q: the seeded models, the column layout and every scratch
/// array, set up once. Per group of parameters, with s = dq/dp solved
/// from (S1), one evaluation of the Jacobian at q' = s (its tangent
/// D(J) = Phi_qq[s, .] + J_p, so D(J) qd = A s + J_p qd of S6 without
/// forming A) serves (S2) and (S3): the cost is the lanes' own, whatever
/// the number of parameters; Phi_p and nu_p are taken over the moved
/// families alone.
pub struct Lanewise<'a, const N: usize> {
    kin: &'a Kin,
    layout: &'a Layout,
    groups: &'a [Group<N>],
    /// the named points' columns over the set-up's pc (their layout of
    /// `levels` stages: Columns::point_tangents)
    columns: crate::columns::Columns<'a>,
    locs: &'a [Vec<Complex<Lanes<N>>>],
    /// its own buffers and figures (`LaneRoom`), moved in and out whole
    room: LaneRoom<N>,
}

impl<'a, const N: usize> Lanewise<'a, N> {
    /// The set-up of a run of instants: the kept groups and points'
    /// local coordinates, the column layout and every scratch array.
    fn new(
        p: &'a Prepared,
        groups: &'a [Group<N>],
        locs: &'a [Vec<Complex<Lanes<N>>>],
        layout: &'a Layout,
        levels: usize,
    ) -> Self {
        let (kin, src, pc) = (&p.kin, &p.src, &p.pc);
        let (w, points) = (src.len(), p.points);
        let (n, m, nnz, np) = (kin.n, kin.m, kin.nnz, p.np);
        let flat = 3 * n + 2 * levels * points;
        // (a point's value i, entry i p + j of `points`' pts, is row 2 levels j + i after s, sd, sdd:
        // Columns::point_tangents)
        let row = |j: usize| match j.checked_sub(levels * n) {
            None => j,
            Some(v) if points > 0 => 3 * n + 2 * levels * (v % points) + v / points,
            Some(v) => 3 * n + v,
        };
        let gather: Vec<usize> = src.iter().map(|&j| row(j)).collect();
        assert!(gather.iter().all(|&i| i < flat), "sensitivity: a column's source out of range");
        let (mut triples, mut singles, mut c) = (Vec::new(), Vec::new(), 0);
        while c < w {
            if c + 2 < w && gather[c + 1] == gather[c] + 1 && gather[c + 2] == gather[c] + 2 {
                triples.push((c, gather[c]));
                c += 3;
            } else {
                singles.push((c, gather[c]));
                c += 1;
            }
        }
        // (every group's Direct ranges end within its `kept`, and kv, kd hold the largest: `at` slices them unchecked)
        // (and every Direct's rows end within the m rows of rhs, rhs3)
        assert!(groups
            .iter()
            .all(|g| g.direct.iter().all(|f| f.v.end <= g.kept.0 && f.d.end <= g.kept.1 && f.rows.end <= m)));
        let zl = || vec![Lanes::<N>::c(0.0); n];
        let cl = || vec![Complex::new(Lanes::<N>::c(0.0), Lanes::<N>::c(0.0)); n];
        // (one group alone: with several, their reach is nearly every place's, and the
        // groups would share flat's rows: each its whole pass, or its fixed row)
        let one = groups.len() == 1;
        let reach: Vec<Reach<N>> = groups.iter().zip(locs).map(|(g, l)| Reach::new(p, g, l, layout, one)).collect();
        // (every reach's rows within rhs (m rows) and s (n coordinates): Solver::solve_in)
        assert!(reach.iter().all(|r| r.rows.iter().all(|&(i, c)| (i as usize) < m && (c as usize) < n)));
        // (and every restricted program's places within n and rows within m: Restricted::run_unchecked)
        assert!(reach.iter().all(|r| r.program.iter().all(|p| p.bounds.0 <= n && p.bounds.1 <= m)));
        // (and every list's columns within n and rows within m, rhs's and rhs3's: `at` reads them unchecked)
        assert!(reach.iter().all(|r| {
            let fits = |(c, row): (usize, usize)| c < n && row < m;
            r.lists.pins.iter().all(|x| fits(x.bounds())) && r.lists.slides.iter().all(|x| fits(x.bounds()))
        }));
        assert!(groups.iter().all(|g| g.phi_pins.iter().all(|x| x.bounds().0 < n && x.bounds().1 < m)));
        // (and the named points' columns, local coordinates and the points taken within bounds, their
        // tangents' room 2 levels a point: `at` calls Columns::point_tangents_unchecked)
        assert!(pc.len() == points && pc.iter().all(|&c| c + 2 < n) && locs.iter().all(|l| l.len() >= points));
        assert!(reach.iter().all(|r| r.points.iter().all(|&j| j < points)) && (1..=3).contains(&levels));
        let pk = vec![PinKept::default(); reach.iter().map(|r| r.lists.pins.len()).max().unwrap_or(0)];
        let sk = vec![SlideKept::default(); reach.iter().map(|r| r.lists.slides.len()).max().unwrap_or(0)];
        let room = LaneRoom {
            np,
            levels,
            w,
            turned: pc.iter().all(|&c| kin.angles.contains(&(c + 2))),
            lanes0: groups.iter().any(|g| g.moved_lanes),
            flat: vec![[0.0; N]; flat],
            buf: vec![[0.0; N]; w],
            gather,
            triples,
            singles,
            q0: zl(),
            e0: vec![Complex::new(Lanes::<N>::c(1.0), Lanes::<N>::c(0.0)); n],
            ql: zl(),
            qdl: zl(),
            el: cl(),
            rl: vec![Lanes::<N>::c(0.0); m],
            jl: vec![Lanes::<N>::c(0.0); nnz],
            rhs: vec![[0.0; N]; m],
            rhs3: vec![[0.0; N]; m],
            kv: vec![C64::new(0.0, 0.0); groups.iter().map(|g| g.kept.0).max().unwrap_or(0)],
            kd: vec![[0.0; N]; groups.iter().map(|g| g.kept.1).max().unwrap_or(0)],
            solver: Solver::new(n, m, 3 * np >= 2 * n && n <= INVERSE),
            reach,
            pk,
            sk,
        };
        let mut at = Self::enter(p, groups, locs, layout, room);
        for g in 0..groups.len() {
            at.fix(g);
        }
        at
    }

    /// A group's whole output where its shift is known (`moving`, Reach's
    /// `fixed`) and no named point's local coordinates move: s the shift,
    /// sd = sdd = 0, the points' tangents from them (the shift's x and y;
    /// zero velocities and accelerations, whatever the instant's values).
    fn fix(&mut self, g: usize) {
        let (group, n, w, levels) = (&self.groups[g], self.kin.n, self.room.w, self.room.levels);
        let Some(shift) = &group.shift else { return };
        let locs = &self.locs[g];
        if locs.iter().any(|z| z.re.d.iter().chain(&z.im.d).any(|&x| x != 0.0)) {
            return;
        }
        self.room.flat.fill([0.0; N]);
        self.room.flat[..n].copy_from_slice(shift);
        let zeros = vec![0.0; n];
        let x = [&zeros[..], &zeros[..], &zeros[..]];
        let all: Vec<usize> = (0..locs.len()).collect();
        let (tangents, points) = self.room.flat.split_at_mut(3 * n);
        let d: [&[[f64; N]]; 3] = [&tangents[..n], &tangents[n..2 * n], &tangents[2 * n..]];
        self.columns.point_tangents(&x[..levels], &d[..levels], locs, |_| C64::new(1.0, 0.0), &all, points);
        let mut row = vec![0.0; group.count * w];
        for (lane, to) in row.chunks_mut(w).enumerate() {
            for (o, &i) in to.iter_mut().zip(&self.room.gather) {
                *o = self.room.flat[i][lane];
            }
        }
        self.room.flat.fill([0.0; N]);
        self.room.reach[g].fixed = Some(row);
    }

    /// A run in the room a run of the same set-up, layout and levels left
    /// (`Room`): `new`'s figures, nothing made again.
    fn enter(
        p: &'a Prepared,
        groups: &'a [Group<N>],
        locs: &'a [Vec<Complex<Lanes<N>>>],
        layout: &'a Layout,
        room: LaneRoom<N>,
    ) -> Self {
        // (the points' columns alone: no column sources, nothing allocated)
        let columns = crate::columns::Columns::new(p.kin.n, room.levels, &[], &p.pc);
        Lanewise { kin: &p.kin, layout, groups, columns, locs, room }
    }

    /// The run's own fields, for `enter`.
    fn leave(self) -> LaneRoom<N> {
        self.room
    }

    /// The columns per instant and parameter (P W: an instant's row of data).
    pub fn width(&self) -> usize {
        self.room.np * self.room.w
    }

    /// One instant: x its stages (q, qd, qdd: `levels` of n), e e^{i q} at
    /// the angle columns (the march's own), f the factorisation of Phi_q at
    /// (q, t) (its solves leave it as it is), pivot its pivot ratio where
    /// the caller has it (the march's, 0 where below SINGULAR: then taken
    /// from f), pieces the pieces f's outlines were taken on (m: the
    /// march's, Kin::jac_over_keeping; or empty: found again); writes its
    /// row (P W) and returns Phi_q's pivot ratio. The families with direct kernels
    /// (Family::phi_tangent, jac_products, gamma_tangent) read x and e as
    /// they are; the others are evaluated over the lanes (q, e^{i q}, qd
    /// with their tangents), and so are the named points' tangents
    /// (Columns::point_tangents) from x, e and s, sd, sdd.
    #[allow(clippy::too_many_arguments)]
    pub fn at(
        &mut self,
        t: f64,
        x: &[&[f64]],
        e: &[C64],
        pieces: &[Piece],
        f: &mut Factors,
        pivot: f64,
        out: &mut [f64],
    ) -> f64 {
        let (kin, layout, levels) = (self.kin, self.layout, self.room.levels);
        assert!(pieces.is_empty() || pieces.len() >= kin.m);
        let n = kin.n;
        let q = x[0];
        // (the lists' kernels read the stages and e unchecked: `Lists`)
        // (and the points' tangents read the stages unchecked: Columns::point_tangents_unchecked)
        assert!(
            e.len() >= n
                && x.len() >= levels
                && levels >= 1
                && q.len() >= n
                && (levels < 2 || x[1].len() >= n)
                && (levels < 3 || x[2].len() >= n)
        );
        let ratio = if pivot > 0.0 { pivot } else { layout.pivots(f).0 };
        if self.room.lanes0 {
            for j in 0..n {
                self.room.q0[j] = Lanes::<N>::c(q[j]);
            }
            for &j in &kin.angles {
                self.room.e0[j] = Complex::new(Lanes::<N>::c(e[j].re), Lanes::<N>::c(e[j].im));
            }
        }
        self.room.solver.prepare(layout, f);
        // the restricted solves' checks, once an instant (Solver::solve_in: no inverse, the blocks' factors)
        let quick =
            !self.room.solver.use_inverse && matches!(layout.shape, Shape::Triangular(_)) && f.fixed[0].is_some();
        for g in 0..self.groups.len() {
            // SAFETY: the stages, e and pieces as `group_at` reads them (asserted above)
            unsafe { self.group_at(g, t, x, e, pieces, f, quick, out) };
        }
        ratio
    }

    /// One group's part of `at` (the body of its loop over the groups, out
    /// of line: P = 1's single group pays no set-up of a loop's invariants,
    /// made before the loop and kept on the stack when inlined).
    ///
    /// # Safety
    /// What `at` asserts on x, e and pieces: pieces empty or m long, e and
    /// the `levels` stages of x n long, levels at least 1.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn group_at(
        &mut self,
        g: usize,
        t: f64,
        x: &[&[f64]],
        e: &[C64],
        pieces: &[Piece],
        f: &mut Factors,
        quick: bool,
        out: &mut [f64],
    ) {
        let (kin, layout, levels, w) = (self.kin, self.layout, self.room.levels, self.room.w);
        // a family's pieces, at its rows (row_off ascends to m: Kin::new)
        let pieces_of =
            |k: usize| if pieces.is_empty() { &[][..] } else { &pieces[kin.row_off[k]..kin.row_off[k + 1]] };
        let (n, q) = (kin.n, x[0]);
        let at0 = At { q: &self.room.q0, e: &self.room.e0, t };
        let atf = At { q, e, t };
        let group = &self.groups[g];
        let (model, count) = (&group.model, group.count);
        let reach = &self.room.reach[g];
        let program = reach.program.as_ref().filter(|p| quick && f.j.len() >= p.bounds.2);
        if let Some(row) = &reach.fixed {
            out[g * N * w..(g * N + count) * w].copy_from_slice(row);
            return;
        }
        let shared = Shared { functions: &model.functions, outlines: &model.outlines };
        // S1: -Phi_p, Phi's tangent at q' = 0, non-zero in the moved families' rows alone
        self.room.rhs.fill([0.0; N]);
        for (k, hand) in group.phi_rest.iter().copied() {
            let rows = model.row_off[k]..model.row_off[k + 1];
            let family = &model.families[k];
            let keep = match hand {
                Some(i) if levels > 1 => {
                    let f = &group.direct[i];
                    // SAFETY: every Direct's ranges within kv, kd (asserted in `new`)
                    unsafe {
                        Kept::of(
                            self.room.kv.get_unchecked_mut(f.v.clone()),
                            self.room.kd.get_unchecked_mut(f.d.clone()),
                        )
                    }
                }
                _ => Kept::none(),
            };
            let keep = Kept { pieces: if hand.is_some() { pieces_of(k) } else { &[] }, ..keep };
            if !family.phi_tangent(&atf, &shared, &mut self.room.rhs[rows.clone()], keep) {
                family.phi(&at0, &shared, &mut self.room.rl[rows.clone()]);
                for (r, x) in self.room.rhs[rows.clone()].iter_mut().zip(&self.room.rl[rows]) {
                    *r = x.d.map(|v| -v);
                }
            }
        }
        // SAFETY: every PhiPin's columns below n (e's: asserted above) and rows below m (asserted in `new`)
        unsafe { phi_pins(&group.phi_pins, e, &mut self.room.rhs) };
        self.room.solver.solve_in(layout, f, &self.room.rhs, count, &mut self.room.flat[..n], reach, program);
        let lanes = !group.live.is_empty();
        if lanes {
            // q with tangent s, and e^{i q} with its tangent (Real::sin, cos)
            for j in 0..n {
                self.room.ql[j] = Lanes::of(q[j], self.room.flat[j]);
            }
            for &j in &kin.angles {
                self.room.el[j] = turned(e[j], self.room.flat[j]);
            }
        }
        let at = At { q: &self.room.ql, e: &self.room.el, t };
        if levels > 1 {
            // S2: nu_p - D(J) qd, D(J) the Jacobian's tangent at q' = s
            for &k in &group.live {
                model.families[k].jac(&at, &shared, &mut self.room.jl[model.entry_off[k]..model.entry_off[k + 1]]);
            }
            self.room.rhs.fill([0.0; N]);
            for &k in &group.timed {
                let rows = model.row_off[k]..model.row_off[k + 1];
                model.families[k].nu(t, &shared, &mut self.room.rl[rows.clone()]);
                for (r, x) in self.room.rhs[rows.clone()].iter_mut().zip(&self.room.rl[rows]) {
                    *r = x.d;
                }
            }
            products(&group.entries, &self.room.jl, &x[1..], &mut self.room.rhs, &mut self.room.rhs3);
            let (s, rhs, rhs3) = (&self.room.flat[..n], &mut self.room.rhs, &mut self.room.rhs3);
            for f in reach.direct.iter().map(|&i| &group.direct[i]) {
                // SAFETY: every Direct's ranges within kv, kd and its rows within rhs, rhs3 (asserted in `new`)
                // (what its phi_tangent kept, `held`, read)
                let (r2, r3, keep) = unsafe {
                    let keep = if levels > 2 || f.held {
                        Kept {
                            v: self.room.kv.get_unchecked_mut(f.v.clone()),
                            d: self.room.kd.get_unchecked_mut(f.d.clone()),
                            held: f.held,
                            pieces: if f.held { &[] } else { pieces_of(f.k) },
                        }
                    } else {
                        Kept { pieces: pieces_of(f.k), ..Kept::none() }
                    };
                    let r3 = if levels > 2 { rhs3.get_unchecked_mut(f.rows.clone()) } else { &mut [][..] };
                    (rhs.get_unchecked_mut(f.rows.clone()), r3, keep)
                };
                let d = Dir { at: At { q, e, t }, qd: x[1], s, sd: &[], moved: f.moved, drives: group.drives };
                model.families[f.k].jac_products(&d, &shared, &x[1..], r2, r3, keep);
            }
            // the revolute joints and point-on-line constraints, one list each (`Lists`)
            let (lists, qd, qdd) = (&reach.lists, x[1], if levels > 2 { x[2] } else { &[][..] });
            let (pk, sk) = (&mut self.room.pk, &mut self.room.sk);
            let (pins, slides) = (lists.pins.split_at(lists.pins_moved), lists.slides.split_at(lists.slides_moved));
            // SAFETY: every list's columns below n (which q, e, s, qd and qdd hold: asserted above) and rows
            // below m (rhs's and rhs3's), pk and sk as long as the longest lists (asserted in `new`)
            unsafe {
                if levels > 2 {
                    pins_products::<N, false, true>(pins.0, e, s, qd, qdd, rhs, rhs3, pk);
                    pins_products::<N, true, true>(pins.1, e, s, qd, qdd, rhs, rhs3, &mut pk[pins.0.len()..]);
                    slides_products::<N, false, true>(slides.0, q, e, s, qd, qdd, rhs, rhs3, sk);
                    let sk = &mut sk[slides.0.len()..];
                    slides_products::<N, true, true>(slides.1, q, e, s, qd, qdd, rhs, rhs3, sk);
                } else {
                    pins_products::<N, false, false>(pins.0, e, s, qd, qdd, rhs, rhs3, pk);
                    pins_products::<N, true, false>(pins.1, e, s, qd, qdd, rhs, rhs3, pk);
                    slides_products::<N, false, false>(slides.0, q, e, s, qd, qdd, rhs, rhs3, sk);
                    slides_products::<N, true, false>(slides.1, q, e, s, qd, qdd, rhs, rhs3, sk);
                }
            }
            self.room.solver.solve_in(layout, f, &self.room.rhs, count, &mut self.room.flat[n..2 * n], reach, program);
            if lanes {
                for j in 0..n {
                    self.room.qdl[j] = Lanes::of(x[1][j], self.room.flat[n + j]);
                }
            }
        }
        if levels > 2 {
            // S3: D(gamma) (along q' = s, qd' = sd and the tables') - D(J) qdd
            for &k in &group.live {
                let rows = model.row_off[k]..model.row_off[k + 1];
                model.families[k].gamma(&at, &self.room.qdl, &shared, &mut self.room.rl[rows]);
            }
            for &k in &group.live {
                let rows = model.row_off[k]..model.row_off[k + 1];
                for (r, x) in self.room.rhs3[rows.clone()].iter_mut().zip(&self.room.rl[rows]) {
                    for l in 0..N {
                        r[l] += x.d[l];
                    }
                }
            }
            let (s, sd) = (&self.room.flat[..n], &self.room.flat[n..2 * n]);
            for f in reach.direct.iter().map(|&i| &group.direct[i]) {
                let d = Dir { at: At { q, e, t }, qd: x[1], s, sd, moved: f.moved, drives: group.drives };
                // SAFETY: as in (S2)
                let (v, kd, r3) = unsafe {
                    let (v, kd) =
                        (self.room.kv.get_unchecked_mut(f.v.clone()), self.room.kd.get_unchecked_mut(f.d.clone()));
                    (v, kd, self.room.rhs3.get_unchecked_mut(f.rows.clone()))
                };
                model.families[f.k].gamma_tangent(&d, &shared, r3, Kept::of(v, kd));
            }
            let lists = &reach.lists;
            // SAFETY: as in (S2), sd n long
            unsafe {
                pins_gamma(&lists.pins, x[1], sd, &mut self.room.rhs3, &self.room.pk);
                slides_gamma(&lists.slides, x[1], sd, &mut self.room.rhs3, &self.room.sk);
            }
            self.room.solver.solve_in(
                layout,
                f,
                &self.room.rhs3,
                count,
                &mut self.room.flat[2 * n..3 * n],
                reach,
                program,
            );
        }
        // every column's tangent: a coordinate's from s, sd, sdd, a named
        // point's from x, e and them (crate::columns)
        let (tangents, points) = self.room.flat.split_at_mut(3 * n);
        let d: [&[[f64; N]]; 3] = [&tangents[..n], &tangents[n..2 * n], &tangents[2 * n..]];
        // SAFETY: the stages n long (asserted above, s, sd, sdd n each), the points' columns, their
        // local coordinates, `points` and reach.points within bounds (asserted in `new`)
        unsafe {
            let (cols, locs, taken) = (&self.columns, &self.locs[g], &reach.points);
            if self.room.turned {
                cols.point_tangents_unchecked(x, &d[..levels], locs, |c| e[c], taken, points);
            } else {
                cols.point_tangents_unchecked(x, &d[..levels], locs, |c| cis(q[c]), taken, points);
            }
        }
        let to = &mut out[g * N * w..(g * N + count) * w];
        if N == 1 {
            // SAFETY: every gather index below flat.len() (asserted in `new`), every column c
            // (c + 2 of a triple) below w = to.len()
            unsafe {
                for &(c, i) in &self.room.triples {
                    let (x, o) = (self.room.flat.get_unchecked(i..i + 3), to.get_unchecked_mut(c..c + 3));
                    (o[0], o[1], o[2]) = (x[0][0], x[1][0], x[2][0]);
                }
                for &(c, i) in &self.room.singles {
                    *to.get_unchecked_mut(c) = self.room.flat.get_unchecked(i)[0];
                }
            }
        } else {
            // gathered once, then a lane at a time (fewer index checks)
            for (b, &i) in self.room.buf.iter_mut().zip(&self.room.gather) {
                // SAFETY: every gather index below flat.len() (asserted in `new`)
                *b = unsafe { *self.room.flat.get_unchecked(i) };
            }
            for (lane, to) in to.chunks_mut(w).enumerate() {
                for (o, b) in to.iter_mut().zip(&self.room.buf) {
                    *o = b[lane];
                }
            }
        }
    }
}

/// e^{i q} over the lanes from e = e^{i q} and q's tangents d: cis of q
/// with tangents d (Real::cos, sin) to the bit, where e = (cos q, sin q).
#[inline(always)]
fn turned<const N: usize>(e: C64, d: [f64; N]) -> Complex<Lanes<N>> {
    let (c, s) = (e.re, e.im);
    Complex::new(Lanes::of(c, d.map(|x| x * -s)), Lanes::of(s, d.map(|x| x * c)))
}

/// The (S2) and (S3) products with D(J) (its tangents at the entries
/// that may be non-zero: row, column, place in dj, `entries`), in one pass:
/// r2 -= D(J) v[0] (qd) and r3 = -D(J) v[1] (qdd, when given).
fn products<const N: usize>(
    entries: &[(usize, usize, usize)],
    dj: &[Lanes<N>],
    v: &[&[f64]],
    r2: &mut [[f64; N]],
    r3: &mut [[f64; N]],
) {
    let qd = v[0];
    if let Some(qdd) = v.get(1) {
        r3.fill([0.0; N]);
        for &(i, j, p) in entries {
            let (a, b, d) = (qd[j], qdd[j], &dj[p].d);
            let (x, y) = (&mut r2[i], &mut r3[i]);
            for l in 0..N {
                x[l] -= d[l] * a;
                y[l] -= d[l] * b;
            }
        }
    } else {
        for &(i, j, p) in entries {
            let (a, d, x) = (qd[j], &dj[p].d, &mut r2[i]);
            for l in 0..N {
                x[l] -= d[l] * a;
            }
        }
    }
}

/// Models of at most this many coordinates solve many parameters' systems
/// through Phi_q's inverse, formed at each instant from its factors (n
/// solves, then a product per N parameters), where that takes fewer
/// solves than one per parameter and level (3 P >= 2 n).
pub const INVERSE: usize = 64;

/// The instant's solves of N right-hand sides: through the inverse
/// (`inverse`: n x m, row-major), all N at once with a block-triangular
/// layout's factors (Triangular::run over [f64; N], triangular::Cell), or one by one with the factors.
struct Solver<const N: usize> {
    use_inverse: bool,
    /// the inverse's entries that are not exactly zero (a block-triangular
    /// Phi_q has a block-triangular inverse), row by row: (column, value)
    /// for row j at start[j]..start[j + 1]
    inverse: Vec<(usize, f64)>,
    start: Vec<usize>,
    dense: Vec<f64>,
    b: Vec<f64>,
    x: Vec<f64>,
    /// N unit right-hand sides and their solutions (`prepare`)
    units: Vec<[f64; N]>,
    columns: Vec<[f64; N]>,
}

impl<const N: usize> Solver<N> {
    fn new(n: usize, m: usize, use_inverse: bool) -> Self {
        Solver {
            use_inverse,
            inverse: Vec::with_capacity(if use_inverse { n * m } else { 0 }),
            start: vec![0; n + 1],
            dense: vec![0.0; if use_inverse { n * m } else { 0 }],
            b: vec![0.0; m],
            x: vec![0.0; n],
            units: vec![[0.0; N]; if use_inverse { m } else { 0 }],
            columns: vec![[0.0; N]; if use_inverse { n } else { 0 }],
        }
    }

    /// The inverse from the instant's factors (when it is used); its zeros
    /// are left out of the products (adding them changes no sum).
    fn prepare(&mut self, layout: &Layout, f: &mut Factors) {
        if !self.use_inverse {
            return;
        }
        let m = self.b.len();
        if let (Shape::Triangular(t), Some(_)) = (&layout.shape, &f.fixed[0]) {
            // N columns of the inverse per solve (Triangular::run: each its own solve's to the bit)
            let (b, x) = (&mut self.units, &mut self.columns);
            for from in (0..m).step_by(N) {
                b.fill([0.0; N]);
                for l in 0..N.min(m - from) {
                    b[from + l][l] = 1.0;
                }
                t.run(&f.j, b, x);
                for (j, v) in x.iter().enumerate() {
                    for l in 0..N.min(m - from) {
                        self.dense[j * m + from + l] = v[l];
                    }
                }
            }
        } else {
            for i in 0..m {
                self.b.fill(0.0);
                self.b[i] = 1.0;
                layout.solve(f, &self.b, &mut self.x);
                for (j, &v) in self.x.iter().enumerate() {
                    self.dense[j * m + i] = v;
                }
            }
        }
        self.inverse.clear();
        for (j, row) in self.dense.chunks(m).enumerate() {
            self.inverse.extend(row.iter().enumerate().filter(|e| *e.1 != 0.0).map(|(i, &v)| (i, v)));
            self.start[j + 1] = self.inverse.len();
        }
    }

    /// `solve` where a group's parameters reach only some places (`Reach`):
    /// the rows reached copied to their places and the restricted program
    /// run there with the blocks' factors (the other places stay zero):
    /// `quick`, the reach's program where the instant has the blocks'
    /// factors and no inverse is used (`Lanewise::at` decides it once an
    /// instant); or the full solve and its places not reached zeroed (they
    /// are zero but for the fallback's or the inverse's rounding).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn solve_in(
        &mut self,
        layout: &Layout,
        f: &mut Factors,
        rhs: &[[f64; N]],
        count: usize,
        out: &mut [[f64; N]],
        reach: &Reach<N>,
        quick: Option<&Restricted>,
    ) {
        if let Some(program) = quick {
            // SAFETY: its places below n <= out.len(), its rows below m <= rhs.len() (asserted in
            // Lanewise::new), its factors below f.j.len() (Lanewise::group_at passes it only then)
            return unsafe { program.run_unchecked(&f.j, rhs, out) };
        }
        if reach.program.is_none() {
            return self.solve(layout, f, rhs, count, out);
        }
        self.solve(layout, f, rhs, count, out);
        for &c in &reach.zero {
            out[c as usize] = [0.0; N];
        }
    }

    /// out = Phi_q^-1 rhs for the first `count` lanes (inlined in
    /// Lanewise::at: its branches are decided once per call).
    #[inline(always)]
    fn solve(&mut self, layout: &Layout, f: &mut Factors, rhs: &[[f64; N]], count: usize, out: &mut [[f64; N]]) {
        if self.use_inverse {
            for (j, o) in out.iter_mut().enumerate() {
                let mut acc = [0.0; N];
                for &(i, a) in &self.inverse[self.start[j]..self.start[j + 1]] {
                    let r = &rhs[i];
                    for l in 0..N {
                        acc[l] += a * r[l];
                    }
                }
                *o = acc;
            }
            return;
        }
        if N == 1 {
            // one lane: the solve reads and writes the lane arrays as they are
            layout.solve(f, rhs.as_flattened(), out.as_flattened_mut());
            return;
        }
        if let (Shape::Triangular(t), Some(_)) = (&layout.shape, &f.fixed[0]) {
            return t.run(&f.j, rhs, out);
        }
        for l in 0..count {
            for (b, r) in self.b.iter_mut().zip(rhs) {
                *b = r[l];
            }
            layout.solve(f, &self.b, &mut self.x);
            for (o, &v) in out.iter_mut().zip(&self.x) {
                o[l] = v;
            }
        }
    }
}

/// The trajectory's column sources, points' body columns, their local
/// coordinates and (P rows of) tangents: see `sensitivities`.
pub type Cols<'a> = (&'a [usize], &'a [usize], &'a [C64], &'a [C64]);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::functions::POLY;
    use crate::real::cis;

    /// A revolute and a distance driver (a cubic) over three bodies
    /// (as lanes.rs's tests), and a stand-in pattern.
    fn model() -> (Kin, Vec<(usize, usize)>) {
        let mut rev = Table::default();
        rev.ints.insert("ci".into(), vec![0]);
        rev.ints.insert("cj".into(), vec![3]);
        rev.complex.insert("si".into(), vec![C64::new(0.4, 0.1)]);
        rev.complex.insert("sj".into(), vec![C64::new(0.0, -0.5)]);
        let mut dist = Table::default();
        dist.ints.insert("ci".into(), vec![3]);
        dist.ints.insert("cj".into(), vec![6]);
        dist.ints.insert("f".into(), vec![0]);
        dist.complex.insert("si".into(), vec![C64::new(-0.3, 0.2)]);
        dist.complex.insert("sj".into(), vec![C64::new(0.6, 0.6)]);
        let mut f = Table::default();
        f.ints.insert("kind".into(), vec![POLY]);
        f.ints.insert("start".into(), vec![0, 4]);
        f.reals.insert("data".into(), vec![0.9, 0.5, -0.2, 0.1]);
        let fams = vec![("revolute".into(), rev), ("distance".into(), dist)];
        let kin = Kin::new(9, fams, &f, &Table::default(), vec![2, 5, 8]).unwrap();
        let pattern = vec![(0, 0); kin.nnz]; // (the entries' places are what is tested)
        (kin, pattern)
    }

    /// The entries the products over the lanes skip carry a tangent of
    /// exactly zero at every instant: at random (q, q', t), with a moved
    /// revolute's si and a moved cubic's coefficients in the lanes, every
    /// entry the probe (`probe`, over both families) leaves out has
    /// D(J) = 0 (either sign), so the products over
    /// `entries` are the whole pattern's (up to the sign of a zero sum);
    /// and `turned` is cis of q with its tangents to the bit.
    #[test]
    fn the_skipped_entries_are_exactly_zero_and_turned_is_cis() {
        let (kin, pattern) = model();
        let mut si = Table::default();
        si.complex.insert("si".into(), vec![C64::new(1.0, -0.5)]);
        let mut cubic = Table::default();
        cubic.reals.insert("data".into(), vec![0.0, 1.0, 0.0, 0.5]);
        let tangents = [
            Tangent { families: vec![(0, si)], functions: Table::default(), outlines: Table::default() },
            Tangent { families: vec![], functions: cubic, outlines: Table::default() },
        ];
        let group = Group::<2>::new(&kin, &tangents, &pattern).unwrap();
        // the revolute has direct kernels, the distance is over the lanes
        let direct: Vec<(usize, bool)> = group.direct.iter().map(|f| (f.k, f.moved)).collect();
        assert_eq!((&direct[..], &group.live[..]), (&[(0, true)][..], &[1][..]));
        // the probe over both (as it serves any family over the lanes)
        // (the moved families: the revolute, by its si, and the distance, which reads the moved cubic)
        let (live, all) = probe(&group.model, &[0, 1], &pattern);
        assert_eq!(live, [0, 1]);
        assert!(all.len() < pattern.len() && !all.is_empty(), "{all:?}");
        assert_eq!(group.entries.len(), 6);
        let model = &group.model;
        let shared = Shared { functions: &model.functions, outlines: &model.outlines };
        let mut seed = 11u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 6.0 - 3.0
        };
        let (mut j, mut e) = (vec![Lanes::<2>::c(0.0); kin.nnz], vec![Complex::new(Lanes::c(1.0), Lanes::c(0.0)); 9]);
        for _ in 0..200 {
            let q: Vec<Lanes<2>> = (0..9).map(|_| Lanes::of(next(), [next(), next()])).collect();
            for &a in &kin.angles {
                e[a] = turned(cis(q[a].v), q[a].d);
                let c = cis(q[a]);
                assert!([(e[a].re, c.re), (e[a].im, c.im)].iter().all(|(x, y)| x.v.to_bits() == y.v.to_bits()
                    && x.d.iter().zip(&y.d).all(|(u, v)| u.to_bits() == v.to_bits())));
            }
            let at = At { q: &q, e: &e, t: next() };
            for (k, f) in model.families.iter().enumerate() {
                f.jac(&at, &shared, &mut j[model.entry_off[k]..model.entry_off[k + 1]]);
            }
            for (p, x) in j.iter().enumerate() {
                if !all.iter().any(|&(_, _, i)| i == p) {
                    assert!(x.d.iter().all(|&v| v == 0.0), "entry {p}: {:?}", x.d);
                }
            }
        }
    }

    /// The entries Kin::jac_over never writes (Kin::over_kept: the
    /// revolute's I and -I, none of the distance's) are `jac`'s at every
    /// configuration, to the bit (tolerance 0): what lets the march skip
    /// checking its folded and negated pivots' entries (Factors::signs_hold).
    #[test]
    fn the_entries_jac_over_keeps_are_constants_of_jac() {
        let (kin, _) = model();
        let kept = kin.over_kept();
        assert_eq!(kept.iter().filter(|&&k| k).count(), 4, "{kept:?}");
        let mut r = random(7);
        let jac = |q: &[f64]| {
            let e: Vec<C64> = q.iter().map(|&v| cis(v)).collect();
            let mut out = vec![0.0; kin.nnz];
            kin.jac(&crate::families::At { q, e: &e, t: 0.3 }, &mut out);
            out
        };
        let first = jac(&vec![0.0; kin.n]);
        for _ in 0..20 {
            let q: Vec<f64> = (0..kin.n).map(|_| 3.0 * r()).collect();
            let v = jac(&q);
            for k in (0..kin.nnz).filter(|&k| kept[k]) {
                assert_eq!(v[k].to_bits(), first[k].to_bits());
            }
        }
    }

    /// The slider-crank's pattern (its rows) and a block-triangular layout of it.
    fn slider_layout() -> (Vec<usize>, Layout) {
        let (rows, cols) = crate::decompose::tests::slider_crank();
        let n = 12;
        let scale = (0..n).map(|i| 1.0 + 0.1 * i as f64).collect();
        let col_scale = (0..n).map(|j| 2.0 - 0.05 * j as f64).collect();
        let mut layout = crate::plan::one_block(n, &rows, &cols, scale, col_scale);
        let constant: Vec<bool> = rows.iter().map(|&r| r < 3).collect();
        assert!(crate::plan::triangulate(&mut layout, &constant, &constant, &vec![false; rows.len()]));
        (rows, layout)
    }

    /// Uniform numbers in [-1, 1) from a seed.
    fn random(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// The N lanes' solve with a block-triangular layout's factors, and the
    /// inverse formed N columns at a time, are each lane's and each
    /// column's Layout::solve to the bit (the slider-crank's pattern).
    #[test]
    fn the_lanes_solve_is_each_lanes_own_to_the_bit() {
        let (rows, layout) = slider_layout();
        let n = 12;
        let mut next = random(7);
        let mut fixed = 0;
        for _ in 0..50 {
            let values: Vec<f64> = rows.iter().map(|&r| if r < 3 || r == 11 { 1.0 } else { next() }).collect();
            let mut f = layout.factors();
            layout.factor(&values, &mut f);
            let b: Vec<[f64; 4]> = (0..n).map(|_| [next(), next(), 0.0, next() * 1e-3]).collect();
            let mut solver = Solver::<4>::new(n, n, false);
            let mut out = vec![[0.0; 4]; n];
            solver.solve(&layout, &mut f, &b, 4, &mut out);
            fixed += f.fixed[0].is_some() as usize;
            for l in 0..4 {
                let (bl, mut x) = (b.iter().map(|r| r[l]).collect::<Vec<_>>(), vec![0.0; n]);
                layout.solve(&mut f, &bl, &mut x);
                assert!(x.iter().zip(&out).all(|(u, v)| u.to_bits() == v[l].to_bits()), "lane {l}");
            }
            // the inverse, N columns per solve, is each column's own solve
            let mut inverse = Solver::<4>::new(n, n, true);
            inverse.prepare(&layout, &mut f);
            for i in 0..n {
                let (mut e, mut x) = (vec![0.0; n], vec![0.0; n]);
                e[i] = 1.0;
                layout.solve(&mut f, &e, &mut x);
                assert!((0..n).all(|j| x[j].to_bits() == inverse.dense[j * n + i].to_bits()), "column {i}");
            }
        }
        assert!(fixed >= 25, "the blocks' orders taken: {fixed} of 50");
    }

    /// One trial of the restricted-solve tests: the slider-crank's layout
    /// factored at random values (None where the blocks' factors fail), a
    /// set of rows (row `trial` alone for the first 12 trials, then random)
    /// and the program restricted to the places they reach.
    fn reach_trial(
        layout: &Layout,
        rows: &[usize],
        trial: usize,
        next: &mut impl FnMut() -> f64,
    ) -> Option<(Factors, Vec<bool>, Vec<bool>, Program)> {
        let n = 12;
        let Shape::Triangular(t) = &layout.shape else { panic!("the slider-crank's layout is block-triangular") };
        let values: Vec<f64> = rows.iter().map(|&r| if r < 3 || r == 11 { 1.0 } else { next() }).collect();
        let mut f = layout.factors();
        layout.factor(&values, &mut f);
        f.fixed[0].as_ref()?;
        let set: Vec<bool> = (0..n).map(|r| if trial < n { r == trial } else { next() > 0.6 }).collect();
        let mut from = vec![false; n];
        (0..n).filter(|&r| set[r]).for_each(|r| from[t.into[r] as usize] = true);
        let (reached, program) = t.program.reached(&from);
        Some((f, set, reached, program))
    }

    /// A restricted solve (Program::reached, as `Reach` uses it): for right
    /// sides zero but at the rows of a random set, the reached places get
    /// the full solve's figures (but for the sign of a zero) and every
    /// place not reached is exactly zero in the full solve; the slider-crank's
    /// pattern, every row alone and random sets.
    #[test]
    fn a_restricted_solve_is_the_full_ones_at_the_reached_places() {
        let (rows, layout) = slider_layout();
        let n = 12;
        let Shape::Triangular(t) = &layout.shape else { panic!("the slider-crank's layout is block-triangular") };
        let mut next = random(5);
        let (mut partial, mut solved) = (0, 0);
        for trial in 0..60 {
            let Some((mut f, set, reached, program)) = reach_trial(&layout, &rows, trial, &mut next) else { continue };
            solved += 1;
            let b: Vec<f64> = (0..n).map(|r| if set[r] { next() } else { 0.0 }).collect();
            let mut full = vec![0.0; n];
            layout.solve(&mut f, &b, &mut full);
            let mut x = vec![0.0; n];
            for r in (0..n).filter(|&r| reached[t.into[r] as usize]) {
                x[t.into[r] as usize] = b[r];
            }
            program.run(&f.j, &mut x);
            partial += reached.iter().any(|&r| !r) as usize;
            for c in 0..n {
                assert!(x[c] == full[c], "trial {trial}, place {c}: {} against {}", x[c], full[c]);
                assert!(reached[c] || full[c] == 0.0, "trial {trial}: place {c} not reached, {}", full[c]);
            }
        }
        assert!(solved >= 30 && partial >= 5, "{solved} solved, {partial} reaching part of the places");
    }

    /// The restricted program resolved once (`Restricted`, as `Reach`
    /// holds it) gives the rows' copy and the generic run's figures
    /// (Program::run) to the bit, the signs of zeros too, over one lane
    /// and four: the slider-crank's pattern, every row alone and random
    /// sets, right sides zero but at some reached rows (so that the quiet
    /// places' rows are zero at some trials: `short`).
    #[test]
    fn the_resolved_restricted_program_is_the_generic_run_to_the_bit() {
        let (rows, plain) = slider_layout();
        let n = 12;
        // the same with the ground's rows still (quiet positions: the program's `short`)
        let cols = crate::decompose::tests::slider_crank().1;
        let scale = (0..n).map(|i| 1.0 + 0.1 * i as f64).collect();
        let col_scale = (0..n).map(|j| 2.0 - 0.05 * j as f64).collect();
        let mut still = crate::plan::one_block(n, &rows, &cols, scale, col_scale);
        let constant: Vec<bool> = rows.iter().map(|&r| r < 3).collect();
        let ground: Vec<bool> = (0..n).map(|r| r < 3).collect();
        assert!(crate::plan::triangulate_still(&mut still, &constant, &constant, &vec![false; rows.len()], &ground));
        let mut next = random(11);
        let (mut partial, mut solved, mut quiet) = (0, 0, 0);
        for trial in 0..160 {
            let layout = if trial % 2 == 0 { &plain } else { &still };
            let Shape::Triangular(t) = &layout.shape else { panic!("the slider-crank's layout is block-triangular") };
            let Some((f, set, reached, program)) = reach_trial(layout, &rows, trial, &mut next) else { continue };
            solved += 1;
            partial += reached.iter().any(|&r| !r) as usize;
            let kept: Vec<(u32, u32)> =
                (0..n).filter(|&r| reached[t.into[r] as usize]).map(|r| (r as u32, t.into[r])).collect();
            let resolved = Restricted::new(&program, &kept);
            // right sides: random at the set's rows, some of them zero, some -0
            // (the ground's rows zero at half the trials: their places quiet where reached)
            let zero = next() > 0.0;
            let b: Vec<[f64; 4]> = (0..n)
                .map(|r| {
                    std::array::from_fn(|_| {
                        if set[r] && !(zero && r < 3) && next() > -0.6 {
                            next()
                        } else if next() > 0.0 {
                            -0.0
                        } else {
                            0.0
                        }
                    })
                })
                .collect();
            quiet += (!resolved.quiet.is_empty() && resolved.quiet.iter().all(|&r| b[r as usize] == [0.0; 4])) as usize;
            let (mut x, mut y) = (vec![[0.0; 4]; n], vec![[0.0; 4]; n]);
            for &(r, c) in &kept {
                x[c as usize] = b[r as usize];
            }
            program.run(&f.j, &mut x);
            resolved.run(&f.j, &b, &mut y);
            let bits = |v: &[[f64; 4]]| v.iter().flatten().map(|z| z.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&x), bits(&y), "trial {trial}, four lanes");
            // one lane
            let b1: Vec<[f64; 1]> = b.iter().map(|r| [r[0]]).collect();
            let (mut x1, mut y1) = (vec![[0.0; 1]; n], vec![[0.0; 1]; n]);
            for &(r, c) in &kept {
                x1[c as usize] = b1[r as usize];
            }
            program.run(&f.j, &mut x1);
            resolved.run(&f.j, &b1, &mut y1);
            let bits1 = |v: &[[f64; 1]]| v.iter().map(|z| z[0].to_bits()).collect::<Vec<_>>();
            assert_eq!(bits1(&x1), bits1(&y1), "trial {trial}, one lane");
        }
        assert!(solved >= 80 && partial >= 10 && quiet >= 5, "{solved} solved, {partial} partial, {quiet} quiet");
    }
}
