//! Butcher tableaux of the explicit Runge–Kutta methods: the classical RK4, the
//! Dormand–Prince 5(4) pair with its continuous extension (Hairer–Nørsett–Wanner I,
//! §II.5 and §II.6, the coefficients of their `DOPRI5` code) and the Dormand–Prince 8(5,3)
//! triple with its seventh-order continuous extension (§II.10, the coefficients of
//! Hairer's `DOP853` code, `dop853.f`).

use super::controller::{self, Constants};

/// An explicit Runge–Kutta method (strictly lower-triangular `a`).
#[derive(Debug)]
pub struct Tableau {
    /// The method's name, as written in `.mbd` files.
    pub name: &'static str,
    /// Stage nodes `c_i`.
    pub c: &'static [f64],
    /// Stage coefficients, row `i` holding `a_i1 … a_i(i−1)`.
    pub a: &'static [&'static [f64]],
    /// Weights `b_i` of the propagated solution.
    pub b: &'static [f64],
    /// The error estimate (and with it the step-size control).
    pub error: ErrorEstimate,
    /// Order of the propagated solution.
    pub order: u32,
    /// Order of the (highest-order) embedded solution (0 without).
    pub embedded_order: u32,
    /// Whether the last stage is the derivative at the new solution, reused as the next
    /// step's first (first same as last).
    pub fsal: Fsal,
    /// The continuous extension used for output between the ends of a step.
    pub dense: Dense,
}

/// How a method estimates its local error.
#[derive(Debug)]
pub enum ErrorEstimate {
    /// None: the method runs with a fixed step.
    None,
    /// One embedded solution: `err = h Σ eᵢ kᵢ` with `eᵢ = bᵢ − b̂ᵢ`, in the weighted RMS
    /// norm ([`controller::error_norm`]).
    Embedded {
        /// Weights `bᵢ − b̂ᵢ`, one per stage.
        e: &'static [f64],
        /// The controller's constants.
        control: Constants,
    },
    /// The two embedded estimates of DOP853, a fifth-order `err5 = h Σ e5ᵢ kᵢ` and a
    /// third-order `err3 = h Σ e3ᵢ kᵢ`, combined as Hairer's `dop853.f` does
    /// ([`controller::dop853_combine`]).
    Dop853 {
        /// Weights `bᵢ − b̂ᵢ` of the fifth-order estimate (Hairer's `ER`).
        e5: &'static [f64],
        /// Weights `bᵢ − b̃ᵢ` of the third-order estimate (`b̃` Hairer's `BHH`).
        e3: &'static [f64],
        /// The controller's constants.
        control: Constants,
    },
}

impl ErrorEstimate {
    /// The controller's constants (`None`: no error estimate).
    pub fn control(&self) -> Option<Constants> {
        match self {
            ErrorEstimate::None => None,
            ErrorEstimate::Embedded { control, .. } | ErrorEstimate::Dop853 { control, .. } => {
                Some(*control)
            }
        }
    }
}

/// First same as last: whether and when the derivative at a step's result is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fsal {
    /// No: every step evaluates its first stage.
    No,
    /// The last stage row is the weights `b` (`c = 1`): it is evaluated with the others in
    /// every attempt, its state is the result, and after an accepted step it is the next
    /// step's first stage (DOPRI5).
    InStep,
    /// The last stage row is the weights `b` (`c = 1`), but it is not needed by the result
    /// or the error estimate: it is evaluated only once the step is accepted, at the
    /// result, and is the next step's first stage (DOP853, as Hairer's code: a rejected
    /// step costs one evaluation less).
    OnAccept,
}

/// The continuous extension of a method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dense {
    /// None (fixed-step methods report their steps' ends).
    None,
    /// The fourth-order extension of DOPRI5 ([`DOPRI5_DENSE`]).
    Dopri5,
    /// The seventh-order extension of DOP853 ([`DOP853_EXTRA_C`], [`DOP853_EXTRA_A`],
    /// [`DOP853_DENSE_D`]): three more evaluations, only for a step with an output in it.
    Dop853,
}

impl Tableau {
    /// Number of stages (with the FSAL stage).
    pub fn stages(&self) -> usize {
        self.c.len()
    }

    /// The stages evaluated by an attempt (without a FSAL stage evaluated on acceptance).
    pub fn step_stages(&self) -> usize {
        match self.fsal {
            Fsal::OnAccept => self.c.len() - 1,
            Fsal::No | Fsal::InStep => self.c.len(),
        }
    }

    /// The weights of the embedded solutions with their orders, `b − e` per estimate.
    pub fn embedded(&self) -> Vec<(Vec<f64>, u32)> {
        let minus = |e: &[f64]| -> Vec<f64> { self.b.iter().zip(e).map(|(b, e)| b - e).collect() };
        match &self.error {
            ErrorEstimate::None => Vec::new(),
            ErrorEstimate::Embedded { e, .. } => vec![(minus(e), self.embedded_order)],
            ErrorEstimate::Dop853 { e5, e3, .. } => {
                vec![(minus(e5), self.embedded_order), (minus(e3), 3)]
            }
        }
    }
}

/// The classical fourth-order Runge–Kutta method.
pub static RK4: Tableau = Tableau {
    name: "rk4",
    c: &[0.0, 0.5, 0.5, 1.0],
    a: &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]],
    b: &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
    error: ErrorEstimate::None,
    order: 4,
    embedded_order: 0,
    fsal: Fsal::No,
    dense: Dense::None,
};

const B5: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
const B4: [f64; 7] = [
    5179.0 / 57600.0,
    0.0,
    7571.0 / 16695.0,
    393.0 / 640.0,
    -92097.0 / 339200.0,
    187.0 / 2100.0,
    1.0 / 40.0,
];
const E5: [f64; 7] = [
    B5[0] - B4[0],
    B5[1] - B4[1],
    B5[2] - B4[2],
    B5[3] - B4[3],
    B5[4] - B4[4],
    B5[5] - B4[5],
    B5[6] - B4[6],
];

/// The Dormand–Prince 5(4) pair: fifth order propagated (local extrapolation), fourth
/// order embedded for the error estimate, seven stages of which the last is the first of
/// the next step.
pub static DOPRI5: Tableau = Tableau {
    name: "dopri5",
    c: &[0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0],
    a: &[
        &[],
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &B5_ROW,
    ],
    b: &B5,
    error: ErrorEstimate::Embedded {
        e: &E5,
        control: controller::DOPRI5,
    },
    order: 5,
    embedded_order: 4,
    fsal: Fsal::InStep,
    dense: Dense::Dopri5,
};

const B5_ROW: [f64; 6] = [B5[0], B5[1], B5[2], B5[3], B5[4], B5[5]];

/// The coefficients `d_i` of the Dormand–Prince continuous extension (Hairer's `CONTD5`):
/// with `θ = (t − t₀)/h`, `θ₁ = 1 − θ`, `Δ = y₁ − y₀`, `r₃ = h k₁ − Δ`,
/// `r₄ = Δ − h k₇ − r₃`, `r₅ = h Σ dᵢ kᵢ`,
///
/// ```text
/// y(θ) = y₀ + θ (Δ + θ₁ (r₃ + θ (r₄ + θ₁ r₅))),
/// ```
///
/// fourth order uniformly in the step, continuous with its derivative at both ends.
pub const DOPRI5_DENSE: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// The weights `b` of DOP853's eighth-order solution (Hairer's `B1`, `B6`…`B12`; the
/// thirteenth stage, the derivative at the result, has weight 0).
// the published digits of dop853.f, more than an f64 holds
#[allow(clippy::excessive_precision)]
const DOP853_B: [f64; 13] = [
    5.42937341165687622380535766363e-2,
    0.0,
    0.0,
    0.0,
    0.0,
    4.45031289275240888144113950566,
    1.89151789931450038304281599044,
    -5.8012039600105847814672114227,
    3.1116436695781989440891606237e-1,
    -1.52160949662516078556178806805e-1,
    2.01365400804030348374776537501e-1,
    4.47106157277725905176885569043e-2,
    0.0,
];

/// `b` without the thirteenth stage: the row of the FSAL stage.
const DOP853_B_ROW: [f64; 12] = [
    DOP853_B[0],
    DOP853_B[1],
    DOP853_B[2],
    DOP853_B[3],
    DOP853_B[4],
    DOP853_B[5],
    DOP853_B[6],
    DOP853_B[7],
    DOP853_B[8],
    DOP853_B[9],
    DOP853_B[10],
    DOP853_B[11],
];

/// The fifth-order error estimate's weights `b − b̂₅` (Hairer's `ER1`, `ER6`…`ER12`).
#[allow(clippy::excessive_precision)]
const DOP853_E5: [f64; 13] = [
    0.1312004499419488073250102996e-1,
    0.0,
    0.0,
    0.0,
    0.0,
    -0.1225156446376204440720569753e1,
    -0.4957589496572501915214079952,
    0.1664377182454986536961530415e1,
    -0.3503288487499736816886487290,
    0.3341791187130174790297318841,
    0.8192320648511571246570742613e-1,
    -0.2235530786388629525884427845e-1,
    0.0,
];

/// The third-order error estimate's weights `b − b̃₃`, with Hairer's `BHH1`, `BHH2`, `BHH3`
/// on stages 1, 9 and 12 (31/127, 12675/17272, 3/136).
#[allow(clippy::excessive_precision)]
const DOP853_E3: [f64; 13] = [
    DOP853_B[0] - 0.244094488188976377952755905512,
    0.0,
    0.0,
    0.0,
    0.0,
    DOP853_B[5],
    DOP853_B[6],
    DOP853_B[7],
    DOP853_B[8] - 0.733846688281611857341361741547,
    DOP853_B[9],
    DOP853_B[10],
    DOP853_B[11] - 0.220588235294117647058823529412e-1,
    0.0,
];

/// The Dormand–Prince 8(5,3) method (Hairer–Nørsett–Wanner I, §II.10; Hairer's `DOP853`):
/// eighth order propagated, twelve stages per step, two embedded estimates (fifth and third
/// order) combined into one error norm ([`controller::dop853_combine`]), and a thirteenth
/// stage, the derivative at the result, evaluated once the step is accepted and reused as
/// the next step's first ([`Fsal::OnAccept`]): twelve evaluations per accepted step.
#[allow(clippy::excessive_precision)]
pub static DOP853: Tableau = Tableau {
    name: "dop853",
    c: &[
        0.0,
        0.526001519587677318785587544488e-01,
        0.789002279381515978178381316732e-01,
        0.118350341907227396726757197510,
        0.281649658092772603273242802490,
        0.333333333333333333333333333333,
        0.25,
        0.307692307692307692307692307692,
        0.651282051282051282051282051282,
        0.6,
        0.857142857142857142857142857142,
        1.0,
        1.0,
    ],
    a: &[
        &[],
        &[5.26001519587677318785587544488e-2],
        &[
            1.97250569845378994544595329183e-2,
            5.91751709536136983633785987549e-2,
        ],
        &[
            2.95875854768068491816892993775e-2,
            0.0,
            8.87627564304205475450678981324e-2,
        ],
        &[
            2.41365134159266685502369798665e-1,
            0.0,
            -8.84549479328286085344864962717e-1,
            9.24834003261792003115737966543e-1,
        ],
        &[
            3.7037037037037037037037037037e-2,
            0.0,
            0.0,
            1.70828608729473871279604482173e-1,
            1.25467687566822425016691814123e-1,
        ],
        &[
            3.7109375e-2,
            0.0,
            0.0,
            1.70252211019544039314978060272e-1,
            6.02165389804559606850219397283e-2,
            -1.7578125e-2,
        ],
        &[
            3.70920001185047927108779319836e-2,
            0.0,
            0.0,
            1.70383925712239993810214054705e-1,
            1.07262030446373284651809199168e-1,
            -1.53194377486244017527936158236e-2,
            8.27378916381402288758473766002e-3,
        ],
        &[
            6.24110958716075717114429577812e-1,
            0.0,
            0.0,
            -3.36089262944694129406857109825,
            -8.68219346841726006818189891453e-1,
            2.75920996994467083049415600797e1,
            2.01540675504778934086186788979e1,
            -4.34898841810699588477366255144e1,
        ],
        &[
            4.77662536438264365890433908527e-1,
            0.0,
            0.0,
            -2.48811461997166764192642586468,
            -5.90290826836842996371446475743e-1,
            2.12300514481811942347288949897e1,
            1.52792336328824235832596922938e1,
            -3.32882109689848629194453265587e1,
            -2.03312017085086261358222928593e-2,
        ],
        &[
            -9.3714243008598732571704021658e-1,
            0.0,
            0.0,
            5.18637242884406370830023853209,
            1.09143734899672957818500254654,
            -8.14978701074692612513997267357,
            -1.85200656599969598641566180701e1,
            2.27394870993505042818970056734e1,
            2.49360555267965238987089396762,
            -3.0467644718982195003823669022,
        ],
        &[
            2.27331014751653820792359768449,
            0.0,
            0.0,
            -1.05344954667372501984066689879e1,
            -2.00087205822486249909675718444,
            -1.79589318631187989172765950534e1,
            2.79488845294199600508499808837e1,
            -2.85899827713502369474065508674,
            -8.87285693353062954433549289258,
            1.23605671757943030647266201528e1,
            6.43392746015763530355970484046e-1,
        ],
        &DOP853_B_ROW,
    ],
    b: &DOP853_B,
    error: ErrorEstimate::Dop853 {
        e5: &DOP853_E5,
        e3: &DOP853_E3,
        control: controller::DOP853,
    },
    order: 8,
    embedded_order: 5,
    fsal: Fsal::OnAccept,
    dense: Dense::Dop853,
};

/// The nodes of the three extra stages (14, 15, 16) of DOP853's continuous extension.
#[allow(clippy::excessive_precision)]
pub const DOP853_EXTRA_C: [f64; 3] = [0.1, 0.2, 0.777777777777777777777777777778];

/// The coefficients `a_ij` of the three extra stages (rows 14, 15, 16; `j` over all sixteen
/// stages, zero at and after the row's own): they use the step's thirteen stages (the
/// thirteenth the derivative at the result) and the extra stages before them.
#[allow(clippy::excessive_precision)]
pub const DOP853_EXTRA_A: [[f64; 16]; 3] = [
    [
        5.61675022830479523392909219681e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        2.53500210216624811088794765333e-1,
        -2.46239037470802489917441475441e-1,
        -1.24191423263816360469010140626e-1,
        1.5329179827876569731206322685e-1,
        8.20105229563468988491666602057e-3,
        7.56789766054569976138603589584e-3,
        -8.298e-3,
        0.0,
        0.0,
        0.0,
    ],
    [
        3.18346481635021405060768473261e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        2.83009096723667755288322961402e-2,
        5.35419883074385676223797384372e-2,
        -5.49237485713909884646569340306e-2,
        0.0,
        0.0,
        -1.08347328697249322858509316994e-4,
        3.82571090835658412954920192323e-4,
        -3.40465008687404560802977114492e-4,
        1.41312443674632500278074618366e-1,
        0.0,
        0.0,
    ],
    [
        -4.28896301583791923408573538692e-1,
        0.0,
        0.0,
        0.0,
        0.0,
        -4.69762141536116384314449447206,
        7.68342119606259904184240953878,
        4.06898981839711007970213554331,
        3.56727187455281109270669543021e-1,
        0.0,
        0.0,
        0.0,
        -1.39902416515901462129418009734e-3,
        2.9475147891527723389556272149,
        -9.15095847217987001081870187138,
        0.0,
    ],
];

/// The coefficients `d_{r,j}` (`r` = 4…7, Hairer's `D41`…`D716`) of DOP853's continuous
/// extension over the sixteen stages. With `θ = (t − t₀)/h`, `θ₁ = 1 − θ`,
/// `Δ = y₁ − y₀`, `r₂ = h k₁ − Δ`, `r₃ = Δ − h k₁₃ − r₂` and `r_r = h Σ_j d_{r,j} k_j` for
/// r = 4…7 (Hairer's `CONTD8`):
///
/// ```text
/// y(θ) = y₀ + θ (Δ + θ₁ (r₂ + θ (r₃ + θ₁ (r₄ + θ (r₅ + θ₁ (r₆ + θ r₇)))))),
/// ```
///
/// seventh order uniformly in the step.
#[allow(clippy::excessive_precision)]
pub const DOP853_DENSE_D: [[f64; 16]; 4] = [
    [
        -0.84289382761090128651353491142e1,
        0.0,
        0.0,
        0.0,
        0.0,
        0.56671495351937776962531783590,
        -0.30689499459498916912797304727e1,
        0.23846676565120698287728149680e1,
        0.21170345824450282767155149946e1,
        -0.87139158377797299206789907490,
        0.22404374302607882758541771650e1,
        0.63157877876946881815570249290,
        -0.88990336451333310820698117400e-1,
        0.18148505520854727256656404962e2,
        -0.91946323924783554000451984436e1,
        -0.44360363875948939664310572000e1,
    ],
    [
        0.10427508642579134603413151009e2,
        0.0,
        0.0,
        0.0,
        0.0,
        0.24228349177525818288430175319e3,
        0.16520045171727028198505394887e3,
        -0.37454675472269020279518312152e3,
        -0.22113666853125306036270938578e2,
        0.77334326684722638389603898808e1,
        -0.30674084731089398182061213626e2,
        -0.93321305264302278729567221706e1,
        0.15697238121770843886131091075e2,
        -0.31139403219565177677282850411e2,
        -0.93529243588444783865713862664e1,
        0.35816841486394083752465898540e2,
    ],
    [
        0.19985053242002433820987653617e2,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.38703730874935176555105901742e3,
        -0.18917813819516756882830838328e3,
        0.52780815920542364900561016686e3,
        -0.11573902539959630126141871134e2,
        0.68812326946963000169666922661e1,
        -0.10006050966910838403183860980e1,
        0.77771377980534432092869265740,
        -0.27782057523535084065932004339e1,
        -0.60196695231264120758267380846e2,
        0.84320405506677161018159903784e2,
        0.11992291136182789328035130030e2,
    ],
    [
        -0.25693933462703749003312586129e2,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.15418974869023643374053993627e3,
        -0.23152937917604549567536039109e3,
        0.35763911791061412378285349910e3,
        0.93405324183624310003907691704e2,
        -0.37458323136451633156875139351e2,
        0.10409964950896230045147246184e3,
        0.29840293426660503123344363579e2,
        -0.43533456590011143754432175058e2,
        0.96324553959188282948394950600e2,
        -0.39177261675615439165231486172e2,
        -0.14972683625798562581422125276e3,
    ],
];

#[cfg(test)]
mod tests {
    use super::*;

    /// A rooted tree as the list of its children (each a tree).
    #[derive(Clone, Debug)]
    struct Tree(Vec<Tree>);

    impl Tree {
        fn order(&self) -> usize {
            1 + self.0.iter().map(Tree::order).sum::<usize>()
        }
        /// The density γ(t) = |t| Π γ(children).
        fn gamma(&self) -> f64 {
            self.order() as f64 * self.0.iter().map(Tree::gamma).product::<f64>()
        }
        /// Per stage `i`: Π over the children of `Σ_j a_ij Φ_j(child)`, for the stage
        /// coefficients `a` (row `i` holding `a_i1 … a_i(i−1)`, or longer with zeros).
        fn phi(&self, a: &[&[f64]]) -> Vec<f64> {
            let s = a.len();
            let mut out = vec![1.0; s];
            for child in &self.0 {
                let pc = child.phi(a);
                for i in 0..s {
                    let sum: f64 = a[i].iter().zip(&pc).map(|(a, p)| a * p).sum();
                    out[i] *= sum;
                }
            }
            out
        }
    }

    /// Every rooted tree of order `n` (by multisets of smaller trees, in canonical order).
    fn trees(n: usize) -> Vec<Tree> {
        // all trees of each order up to n − 1, indexed
        let mut all: Vec<Vec<Tree>> = vec![Vec::new(), vec![Tree(Vec::new())]];
        for k in 2..=n {
            let mut level = Vec::new();
            // children: a non-increasing sequence of (order, index) with orders summing
            // to k − 1
            fn grow(
                all: &[Vec<Tree>],
                left: usize,
                max: (usize, usize),
                acc: &mut Vec<Tree>,
                out: &mut Vec<Tree>,
            ) {
                if left == 0 {
                    out.push(Tree(acc.clone()));
                    return;
                }
                for o in (1..=left.min(max.0)).rev() {
                    let top = if o == max.0 { max.1 } else { all[o].len() - 1 };
                    for i in (0..=top).rev() {
                        acc.push(all[o][i].clone());
                        grow(all, left - o, (o, i), acc, out);
                        acc.pop();
                    }
                }
            }
            let top = (k - 1, all[k - 1].len() - 1);
            grow(&all, k - 1, top, &mut Vec::new(), &mut level);
            all.push(level);
        }
        all.swap_remove(n)
    }

    fn residual(t: &Tableau, b: &[f64], tree: &Tree) -> f64 {
        let phi: f64 = b.iter().zip(tree.phi(t.a)).map(|(b, p)| b * p).sum();
        phi - 1.0 / tree.gamma()
    }

    #[test]
    fn tree_counts() {
        // 1, 1, 2, 4, 9, 20, 48, 115, 286 rooted trees of orders 1..9 (OEIS A000081)
        let counts: Vec<usize> = (1..=9).map(|n| trees(n).len()).collect();
        assert_eq!(counts, [1, 1, 2, 4, 9, 20, 48, 115, 286]);
    }

    /// The order conditions `Σ bᵢ Φᵢ(t) = 1/γ(t)` over every rooted tree up to the
    /// method's order hold to round-off, and at least one of the next order fails (the
    /// order is exact); the same for each embedded solution `b − e`. The stage rows sum to
    /// the nodes.
    #[test]
    fn order_conditions() {
        for t in [&RK4, &DOPRI5, &DOP853] {
            assert_eq!(t.a.len(), t.stages());
            assert_eq!(t.b.len(), t.stages());
            for (i, row) in t.a.iter().enumerate() {
                assert_eq!(row.len(), i, "{}: row {i}", t.name);
                let sum: f64 = row.iter().sum();
                assert!((sum - t.c[i]).abs() < 1e-14, "{}: c_{i}", t.name);
            }
            let mut weights = vec![(t.b.to_vec(), t.order)];
            weights.extend(t.embedded());
            for (b, p) in weights {
                let mut worst = 0.0f64;
                for n in 1..=p as usize {
                    for tree in trees(n) {
                        let r = residual(t, &b, &tree);
                        worst = worst.max(r.abs());
                        assert!(r.abs() < 1e-14, "{} order {p}: {tree:?}: {r:e}", t.name);
                    }
                }
                let next = trees(p as usize + 1)
                    .iter()
                    .map(|tree| residual(t, &b, tree).abs())
                    .fold(0.0, f64::max);
                eprintln!(
                    "{} order {p}: worst residual {worst:.1e}, next order {next:.1e}",
                    t.name
                );
                assert!(next > 1e-7, "{}: order above {p} ({next:e})", t.name);
            }
        }
    }

    /// FSAL: the last stage row of DOPRI5 is its weights.
    #[test]
    fn dopri5_is_fsal() {
        let last = DOPRI5.a[6];
        for (a, b) in last.iter().zip(DOPRI5.b) {
            assert_eq!(a, b);
        }
        assert_eq!(DOPRI5.b[6], 0.0);
    }

    /// The continuous extension reproduces `t^k`, k ≤ 4, for `y' = k t^(k−1)` (exact
    /// stage derivatives), at interior points: its order conditions `Σ bᵢ(θ) cᵢ^(k−1) =
    /// θ^k/k` on the quadrature trees.
    #[test]
    fn dense_output_quadrature_order() {
        let t = &DOPRI5;
        for &theta in &[0.1, 0.37, 0.5, 0.81] {
            for k in 1..=5 {
                // y = t^k on [0, 1], h = 1, y0 = 0, y1 = 1
                let f: Vec<f64> = t.c.iter().map(|c| k as f64 * c.powi(k - 1)).collect();
                let y0 = 0.0;
                let y1: f64 = t.b.iter().zip(&f).map(|(b, f)| b * f).sum();
                let d = y1 - y0;
                let dk: f64 = DOPRI5_DENSE.iter().zip(&f).map(|(d, f)| d * f).sum();
                let th1 = 1.0 - theta;
                let r3 = f[0] - d;
                let r4 = d - f[6] - r3;
                let y = y0 + theta * (d + th1 * (r3 + theta * (r4 + th1 * dk)));
                let want = theta.powi(k);
                if k <= 4 {
                    assert!((y - want).abs() < 1e-14, "θ {theta}, k {k}: {y} vs {want}");
                }
            }
        }
    }

    /// DOP853's thirteenth stage is the FSAL one: its row is `b`, its node 1, and neither
    /// the result nor the error estimates use it (so it can wait for the step's acceptance).
    #[test]
    fn dop853_fsal_stage_is_evaluated_on_acceptance() {
        let t = &DOP853;
        assert_eq!(t.stages(), 13);
        assert_eq!(t.step_stages(), 12);
        assert_eq!(t.c[12], 1.0);
        assert_eq!(t.a[12], &t.b[..12]);
        assert_eq!(t.b[12], 0.0);
        let ErrorEstimate::Dop853 { e5, e3, .. } = &t.error else {
            panic!("DOP853 has its two estimates");
        };
        assert_eq!((e5.len(), e3.len()), (13, 13));
        assert_eq!((e5[12], e3[12]), (0.0, 0.0));
    }

    /// The weights `bᵢ(θ)` of DOP853's continuous extension over its sixteen stages (the
    /// step's thirteen and the three extra), from Hairer's `CONTD8` form ([`DOP853_DENSE_D`]).
    fn dop853_dense_weights(theta: f64) -> Vec<f64> {
        let th1 = 1.0 - theta;
        (0..16)
            .map(|j| {
                let b = DOP853.b.get(j).copied().unwrap_or(0.0);
                let e1 = if j == 0 { 1.0 } else { 0.0 };
                let e13 = if j == 12 { 1.0 } else { 0.0 };
                let r2 = e1 - b;
                let r3 = b - e13 - r2;
                let d = |r: usize| DOP853_DENSE_D[r][j];
                theta
                    * (b + th1
                        * (r2
                            + theta
                                * (r3
                                    + th1 * (d(0) + theta * (d(1) + th1 * (d(2) + theta * d(3)))))))
            })
            .collect()
    }

    /// DOP853's continuous extension is of order 7: its order conditions
    /// `Σ bᵢ(θ) Φᵢ(t) = θ^|t| / γ(t)` hold to round-off for every rooted tree up to order 7
    /// at interior θ, over the sixteen-stage tableau (the step's thirteen stages and the
    /// three extra rows); some of order 8 fail; at θ = 1 the weights are the step's.
    #[test]
    fn dop853_dense_output_order_conditions() {
        let mut rows: Vec<&[f64]> = DOP853.a.to_vec();
        for (r, row) in DOP853_EXTRA_A.iter().enumerate() {
            let i = 13 + r;
            assert!(row[i..].iter().all(|a| *a == 0.0), "extra row {i}");
            let sum: f64 = row.iter().sum();
            assert!((sum - DOP853_EXTRA_C[r]).abs() < 1e-14, "c_{i}: {sum}");
            rows.push(&row[..i]);
        }
        let mut worst = 0.0f64;
        let mut next = 0.0f64;
        for &theta in &[0.1, 0.37, 0.5, 0.81] {
            let b = dop853_dense_weights(theta);
            for n in 1..=8 {
                for tree in trees(n) {
                    let phi: f64 = b.iter().zip(tree.phi(&rows)).map(|(b, p)| b * p).sum();
                    let r = phi - theta.powi(n as i32) / tree.gamma();
                    if n <= 7 {
                        worst = worst.max(r.abs());
                        assert!(r.abs() < 1e-13, "θ {theta}: {tree:?}: {r:e}");
                    } else {
                        next = next.max(r.abs());
                    }
                }
            }
        }
        eprintln!("dop853 dense output: worst residual to order 7 {worst:.1e}, order 8 {next:.1e}");
        assert!(next > 1e-9, "order above 7 ({next:e})");
        for (j, w) in dop853_dense_weights(1.0).iter().enumerate() {
            let b = DOP853.b.get(j).copied().unwrap_or(0.0);
            assert!((w - b).abs() < 1e-13, "b_{j}(1) = {w} vs {b}");
        }
    }
}
