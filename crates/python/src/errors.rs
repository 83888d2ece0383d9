//! The package's exceptions: `chessarm.Error` and its kinds, and the warning category.

use pyo3::exceptions::PyException;

pyo3::create_exception!(chessarm, Error, PyException, "Every error of chessarm's own (not a wrong argument).");
pyo3::create_exception!(chessarm, ModelError, Error, "A setup file or URDF that chessarm cannot use.");
pyo3::create_exception!(chessarm, UnreachableError, Error, "Inverse kinematics has no solution (reach or limits).");
pyo3::create_exception!(
    chessarm,
    DynamicsError,
    Error,
    "A dynamics computation failed (e.g. M(q) not positive definite)."
);
pyo3::create_exception!(chessarm, CommandError, Error, "A chessarm command failed (the CLI's one-line message).");
pyo3::create_exception!(
    chessarm,
    PlanError,
    Error,
    "A motion chessarm cannot plan (a table the arm cannot serve, a path it cannot follow)."
);
pyo3::create_exception!(
    chessarm,
    SimulationError,
    Error,
    "A simulation that failed (it diverged, a controller that cannot be built)."
);
pyo3::create_exception!(
    chessarm,
    GameError,
    Error,
    "A game that stopped (a move the arm cannot make, an engine that failed)."
);
pyo3::create_exception!(
    chessarm,
    ChessarmWarning,
    pyo3::exceptions::PyUserWarning,
    "What chessarm says about a setup or a study (a URDF's notes, angles outside the limits)."
);
