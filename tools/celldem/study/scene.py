"""The speed–accuracy study's reduced scene and its choices (tools/study.py): what it runs, what it compares.

The paper's settings are read from inputs/paper.json; what a deck implies (steps, the critical time step, the
inertial number) comes from `celldem plan`, saved as plan.json beside each run's deck.json; what a test
measured comes from its summary.json.
"""

from .. import binary, decks

PAPER = decks.load()
_PAPER_TTC = next(t for t in PAPER["tests"] if t["name"] == "ttc")

SCENE_COUNT = 1000          # spheres in the reduced scene (the paper: 8000)
END_STRAIN = 0.03           # ε1 at which the reduced tests end (the paper: 10 %); end values are read here
REF_SEEDS = tuple(range(1, 9))  # reference samples: the noise floor is their seed-to-seed spread
PAPER_DT = PAPER["time_step"]                                    # [s]
PAPER_INC = _PAPER_TTC["axes"]["x1"]["strain_increment"]         # axial strain per step
PAPER_RATE = PAPER_INC / PAPER_DT                                # [1/s]: the study keeps it when it changes dt
PAPER_DAMPING = PAPER["damping"]["translational"]                # fraction, translational and rotational
P_REF = _PAPER_TTC["axes"]["x3"]["stress"]                       # [Pa] confining stress
ROW_STRAIN = 2.0e-4         # ε1 between series rows: the paper's 1000 steps × 2e-7
# The study's own servo criterion: a stress-controlled axis "holds" when the std and the bias of its relative error
# over the run stay below 0.5 %. Not the solver's servo tolerance (servo_tolerance() below), which bounds the
# largest error of any row (summary.json servo_max_error).
SERVO_STD_LIMIT = 0.005
STABILITY_STRAIN = 0.01     # ε1 of the short time step × damping runs
SERVO_STRAIN = 0.015        # the servo runs: ε1 at the end, strain increment per step, steps between rows
SERVO_INC = 5.0e-7
SERVO_OUTPUT_INTERVAL = 25
SERVO_CAP_FACTOR = 5.0      # the study's servo.max_strain_increment: 5 × Δε1 (the paper: 5 × 2e-7 = the default)


def quasi_static_inertial_number(celldem=None):
    """The solver's quasi-static limit of the inertial number (`celldem schema --constants`)."""
    return binary.constant("quasi_static_inertial_number", celldem)


def servo_tolerance(celldem=None):
    """The solver's bound on a stress-controlled axis's largest relative error, servo_max_error
    (`celldem schema --constants`)."""
    return binary.constant("servo_tolerance", celldem)

# The quantities compared, (test, name), each one of summary.json (celldem's definitions): peak_ratio =
# peak_ratio13, e1_peak = e1_at_peak (the row of max σ1/σ3), b_peak = b_at_peak, ev_end and Z_end = the
# end_window means (the last 0.5 % of ε1; the runs end at END_STRAIN, so that is the window before it).
SUMMARY_KEYS = {"peak_ratio": "peak_ratio13", "e1_peak": "e1_at_peak", "b_peak": "b_at_peak",
                "ev_end": "end_window.ev", "Z_end": "end_window.Z"}
QUANTITIES = (
    ("ttc", "peak_ratio"), ("ttc", "e1_peak"), ("ttc", "ev_end"), ("ttc", "Z_end"),
    ("psc", "peak_ratio"), ("psc", "e1_peak"), ("psc", "ev_end"), ("psc", "Z_end"), ("psc", "b_peak"),
)
QUANTITY_LABELS = {
    "peak_ratio": "peak σ1/σ3", "e1_peak": "ε1 at peak", "ev_end": "εv at the end", "Z_end": "Z at the end",
    "b_peak": "b at peak",
}
MODELLING_QUANTITIES = (("ttc", "peak_ratio"), ("ttc", "ev_end"), ("ttc", "Z_end"))

# The stress-ratio quantities (the paper's strength results) and the volumetric and contact ones.
STRESS_QUANTITIES = (("ttc", "peak_ratio"), ("ttc", "e1_peak"), ("psc", "peak_ratio"), ("psc", "e1_peak"),
                     ("psc", "b_peak"))
# Presets: "balanced" keeps every quantity inside the noise floor; "fast" the stress-ratio ones, with εv and Z
# (which a faster loading shifts first) allowed two floors.
PRESET_RULES = {
    "fast": {"stress": 1.0, "volume": 2.0,
             "text": "peak σ1/σ3, ε1 at peak and b inside the noise floor; εv and Z within 2 floors"},
    "balanced": {"stress": 1.0, "volume": 1.0, "text": "every compared quantity inside the noise floor"},
}
DRIFT_FLOORS = 3.0          # a short stability run "drifts" when σ1/σ3 moves by more than 3 TTC peak floors
KE_UNSTABLE = 1.0e-4        # kinetic energy / (p V) above which a run is dynamic (quasi-static runs: ~1e-6)
