"""gipdyn: robot inverse dynamics with Gaussian processes and the GIP kernel.

    >>> import gipdyn
    >>> train = gipdyn.simulate("scara", samples=200, seed=1, dt=0.1)
    >>> test = gipdyn.simulate("scara", samples=100, seed=2, dt=0.1)
    >>> model = gipdyn.InverseDynamicsGP(joints="RRPR").fit(train["X"], train["tau"])
    >>> bool(model.nmse(test["X"], test["tau_true"]).max() < 0.05)
    True

Inputs X are (N, 3n) arrays of [q, qd, qdd] (or tables with columns q1..,
qd1.., qdd1..); torques Y are (N, n).
"""
import inspect
import json
import warnings

import numpy as np

from . import _core
from ._core import __version__, build_info
from ._core import (ContactDetection, ContactOptions, ContactScore, EstimatorOptions, GipdynError, GpOptions,
                    HyperparameterPrior, NeighbourConsistencyOptions, OptimizerOptions, Robot, SearchSettings,
                    SimulatedContacts, SimulationOptions, SparseOptions, TeacherOptions, mpi_rank, mpi_size,
                    score_contacts)

__all__ = ["InverseDynamics", "InverseDynamicsGP", "LagrangianGP", "NotFittedError", "ConvergenceWarning", "NoiseWarning", "TeachingWarning", "DataWarning", "LongFitWarning", "Robot", "EstimatorOptions", "SearchSettings", "GpOptions", "SparseOptions", "TeacherOptions", "OptimizerOptions", "HyperparameterPrior",
           "SimulationOptions", "SimulatedContacts", "simulate", "read_log", "ContactDetector", "ContactOptions",
           "ContactDetection", "ContactScore", "score_contacts", "NeighbourConsistencyOptions", "neighbour_consistency", "nmse", "neg_nmse_scorer", "GipdynError", "mpi_rank", "mpi_size", "build_info"]

try:  # scikit-learn's estimator protocol when it is installed; our own otherwise
    from sklearn.base import BaseEstimator as _BaseEstimator
    from sklearn.base import RegressorMixin as _RegressorMixin
    from sklearn.exceptions import ConvergenceWarning, NotFittedError
    _ESTIMATOR_BASES = (_RegressorMixin, _BaseEstimator)
except ImportError:  # pragma: no cover - exercised only without scikit-learn


    class _BaseEstimator:
        """get_params / set_params / repr from the __init__ signature, as scikit-learn's."""

        @classmethod
        def _get_param_names(cls):
            return [p for p in inspect.signature(cls.__init__).parameters if p != "self"]

        def get_params(self, deep=True):
            return {name: getattr(self, name) for name in self._get_param_names()}

        def set_params(self, **params):
            valid = self._get_param_names()
            for key, value in params.items():
                if key not in valid:
                    raise ValueError(f"invalid parameter {key!r} for {type(self).__name__}; valid: {', '.join(valid)}")
                setattr(self, key, value)
            return self

        def __repr__(self):
            args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
            return f"{type(self).__name__}({args})"

    _ESTIMATOR_BASES = (_BaseEstimator,)

    class ConvergenceWarning(UserWarning):
        """A joint's hyperparameter optimisation stopped before it converged."""

    class NotFittedError(ValueError, AttributeError):
        """A method that needs a fitted model was called before fit (as scikit-learn's)."""


class NoiseWarning(UserWarning):
    """A joint's fit calls most of its torque noise: its predictions stay near the training mean."""


class DataWarning(UserWarning):
    """The training data look wrong in a way a fit cannot fix (e.g. positions in degrees)."""


class LongFitWarning(UserWarning):
    """An exact GP is about to learn its hyperparameters on so many rows that the fit will take long."""


class TeachingWarning(UserWarning):
    """A model taught by a teacher fits the logged rows far worse than its teacher did (teaching_check_)."""


def _warn_unconverged_joints(model, prefix=""):
    """The library's warnings about joints that stopped before converging (see training_report_)."""
    for line in model.convergence_warnings:
        warnings.warn(prefix + line, ConvergenceWarning, stacklevel=3)


def _warn_noisy_joints(model):
    """The library's warning about joints whose fit calls most of the torque noise (see training_report_'s noise_share)."""
    if model.noise_warning:
        warnings.warn(model.noise_warning, NoiseWarning, stacklevel=3)


def _as_matrix(name, a, cols=None, one_row=True):
    """A float64 2-D array (Fortran order is passed to C++ without a copy).

    one_row: a 1-D array of `cols` values is one row; False refuses it, as
    scikit-learn's predict does (predict_one takes a single sample)."""
    if hasattr(a, "tocsr") or type(a).__module__.startswith("scipy.sparse"):
        raise TypeError(f"{name} is a sparse matrix, and sparse input is not supported: pass {name}.toarray()")
    try:
        arr = np.asarray(a)
        complex_data = np.iscomplexobj(arr)  # the conversion would drop the imaginary parts
        if not complex_data:
            arr = arr.astype(np.float64, copy=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be numeric: {e}") from None
    if complex_data:
        raise ValueError(f"{name} holds complex numbers: Complex data not supported; pass its real part")
    # One joint: a 1-D array is one value per row (scikit-learn's y), else one row.
    if arr.ndim == 1 and cols == 1:
        arr = arr.reshape(-1, 1)
    elif arr.ndim == 1 and cols is not None and arr.size == cols and one_row:
        arr = arr.reshape(1, cols)
    if arr.ndim == 1 and not one_row:
        raise ValueError(f"{name} must be a 2-D array, got a 1-D array of {arr.size} values. Reshape your data with "
                         f"{name}.reshape(1, -1) for one sample, or call predict_one")
    if arr.ndim != 2:
        shape = f" (rows x {cols} columns)" if cols is not None else ""
        raise ValueError(f"{name} must be a 2-D array{shape}, got shape {arr.shape}")
    if arr.shape[1] == 0:
        raise ValueError(f"{name} has 0 feature(s) (shape={arr.shape}) while a minimum of 1 is required.")
    if cols is not None and arr.shape[1] != cols:
        raise ValueError(f"{name} must have {cols} columns, got {arr.shape[1]}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name} has no rows")
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} contains NaN or Inf (first at row {bad[0]}, column {bad[1]})")
    return arr


def _by_column_names(name, a, joints, quantities):
    """A table with named columns (a pandas DataFrame) as the matrix of those columns, in the order of the log
    format (q1..qn, qd1..qdn, qdd1..qddn; tau1..taun); any other array as it is."""
    columns = getattr(a, "columns", None)
    if columns is None or isinstance(a, np.ndarray):
        return a
    names = [str(c) for c in columns]
    wanted = [c for quantity in quantities for c in _core.joint_column_names(quantity, len(joints))]
    missing = [c for c in wanted if c not in names]
    if missing:
        raise ValueError(f"{name} has no column {missing[0]!r}: a table's columns are read by name, "
                         f"{', '.join(wanted[:3])}, ... for joints={joints!r} (rename its columns, or pass "
                         f"{name}.to_numpy() with the columns in that order)")
    return np.asarray(a[wanted], dtype=np.float64)


def nmse(Y_true, Y_pred):
    """Per-joint MSE divided by the population variance of Y_true (docs/method.md)."""
    Y_true = np.asarray(Y_true, dtype=float)
    Y_pred = np.asarray(Y_pred, dtype=float)
    if Y_true.shape != Y_pred.shape:
        raise ValueError(f"shapes differ: {Y_true.shape} vs {Y_pred.shape}")
    return ((Y_true - Y_pred) ** 2).mean(axis=0) / Y_true.var(axis=0)


def neg_nmse_scorer(estimator, X, Y):
    """A scikit-learn scorer (greater is better): minus the mean nMSE."""
    return -float(np.mean(estimator.nmse(X, Y)))


def _estimator_row(name):
    """The library's table row of the estimator `name` (estimator_table())."""
    for row in _core.estimator_table():
        if row["name"] == name:
            return row
    raise ValueError(f"unknown estimator {name!r}; one of {', '.join(_core.estimator_names())}")


_DEFAULTS = EstimatorOptions()
_MISSING_JOINTS = ("the joint types are not known, and a log cannot tell a revolute joint from a prismatic one: give "
                   "joints= (one R or P per joint, e.g. joints='RRPR'), robot= (a robot whose joints they are), or "
                   "read the log with gipdyn.read_log(path), whose joints come from the sidecar gipdyn simulate writes")
_TEACHER_DEFAULTS = TeacherOptions()


def _seed(random_state):
    """The library's seed for scikit-learn's random_state: an int as it is, None as 0 (every fit is seeded, so
    the same call gives the same model), a NumPy RandomState or Generator as a draw from it."""
    if random_state is None:
        return 0
    if isinstance(random_state, (np.random.RandomState, np.random.Generator)):
        return int(random_state.integers(2**31) if isinstance(random_state, np.random.Generator)
                   else random_state.randint(2**31))
    try:
        seed = int(random_state)
    except (TypeError, ValueError):
        raise ValueError(f"random_state must be an int, None or a NumPy random generator, got {random_state!r}") from None
    if seed < 0:
        raise ValueError(f"random_state must be >= 0, got {seed}")
    return seed


def _threads(n_jobs):
    """The library's thread count for scikit-learn's n_jobs: None or -1 all cores (the library's 0), else that many.
    Results do not depend on it."""
    if n_jobs is None or int(n_jobs) == -1:
        return 0
    if int(n_jobs) < 1:
        raise ValueError(f"n_jobs must be a positive number of threads, or -1 or None for all cores, got {n_jobs}")
    return int(n_jobs)


# Parameters renamed for scikit-learn's spelling, refused with the new name (no silent aliases).
_RENAMED_SEARCH_PARAMETERS = {"seed": ("random_state", "scikit-learn's name"), "threads": ("n_jobs", "scikit-learn's name")}


# Where each parameter lives in a model file's options block (docs/model-format.md): the inverse of
# estimator_options(), so that load() gives back the parameters that made the model.
_RECORDED_PARAMETERS = {
    "optimizer": ("search", "optimizer"), "max_iter": ("search", "max_iterations"),
    "learning_rate": ("search", "adam_learning_rate"), "restarts": ("search", "restarts"),
    "random_state": ("search", "seed"), "min_noise": ("search", "min_noise_fraction"),
    "gradient_tolerance": ("search", "gradient_tolerance_per_row"),
    "start_screening": ("search", "start_screening_evaluations"),
    "hyperparameter_rows": ("search", "hyperparameter_rows"), "scaling": ("gp", "scaling"), "mean": ("gp", "mean"),
    "prior": ("gp", "prior"), "prior_width": ("gp", "prior_width"), "warm_start_rows": ("gp", "warm_start_rows"),
    "inducing": ("sparse", "inducing_points"), "hyperparameter_objective": ("sparse", "hyperparameter_objective"),
    "serial_chain": (None, "serial_chain"), "robot_friction": (None, "robot_friction"),
}


def _recorded_parameters(cls, model):
    """The parameters of cls that the model file's options and teacher blocks record: the options a
    front end trained it with. A file written before options were recorded gives none of them."""
    names = set(cls._get_param_names()) if hasattr(cls, "_get_param_names") else set(
        inspect.signature(cls.__init__).parameters)
    params = {}
    record = json.loads(model.options_record) if model.options_record else None
    if record is None:
        return params
    for name, (group, key) in _RECORDED_PARAMETERS.items():
        where = record.get(group, {}) if group else record
        if name in names and key in where:
            params[name] = where[key]
    # The file records the starts the search ran; where they are the estimator's own, the parameter is None,
    # as in the fit that left them to the estimator.
    if record.get("estimator") in _core.estimator_names():
        own = _core.estimator_search(record["estimator"], SearchSettings())
        for name, attribute in (("restarts", "restarts"), ("start_screening", "start_screening_evaluations")):
            if name in params and params[name] == getattr(own, attribute):
                params[name] = None
    # The teacher: its block where it taught (or was asked to); none where no teacher was asked for, or where
    # the automatic teacher never applies to these options, which trains the same model.
    if "teacher" in names:
        taught = json.loads(model.teaching_record) if model.teaching_record else None
        if taught is None:
            params["teacher"] = "none"
        else:
            params["teacher"] = "auto" if taught.get("mode") == "automatic" else taught["estimator"]
            for name, key in (("teacher_states", "states"), ("teacher_hyperparameter_rows", "hyperparameter_rows"),
                              ("student_hyperparameter_rows", "student_hyperparameter_rows")):
                if name in names and key in taught:
                    params[name] = taught[key]
    return params


class _RefusesRenamedParameters:
    """Refuses a renamed parameter in one line naming its new spelling, where Python alone would only say that
    the keyword is unexpected (scikit-learn forbids **kwargs in __init__, so __new__ looks first). Each class
    names its own in _RENAMED_PARAMETERS: {old: (new, why)}."""

    _RENAMED_PARAMETERS = _RENAMED_SEARCH_PARAMETERS

    def __new__(cls, *args, **kwargs):
        for old, (new, why) in cls._RENAMED_PARAMETERS.items():
            if old in kwargs:
                raise TypeError(f"{cls.__name__}: the parameter {old}= is now called {new}= ({why})")
        return super().__new__(cls)


class _JointTorqueRegressor(_RefusesRenamedParameters, *_ESTIMATOR_BASES):
    """What every estimator of joint torques shares: one output per joint, the command line's model=, and
    pickling, its fitted model_ (a _MODEL_CLASS of the C++ core) travelling as its model file's bytes, so that
    joblib and GridSearchCV(n_jobs > 1) can copy it before and after fit."""

    _RENAMED_PARAMETERS = {**_RENAMED_SEARCH_PARAMETERS, "kernel": ("model", "as the command line's train --model")}

    def _more_tags(self):
        # Every joint is one output: Y is (N, n), and a 1-D y is the one joint of joints="R" or "P".
        return {"multioutput": True}

    def _training_rows(self, rows):
        """Row indices to train on: a constant-step subsample of `subsample` rows
        (None: the preset's limit, every row without a preset)."""
        limit = self.subsample
        if limit is None:
            limit = _core.preset_max_training_rows(str(self.preset)) if self.preset is not None else 0
        limit = int(limit)
        if limit < 0:
            raise ValueError(f"subsample must be >= 0 (0: every row), got {limit}")
        if limit == 0 or limit >= rows:
            return None
        return (np.arange(limit) * rows) // limit  # as the CLI's --subsample

    @property
    def n_joints(self):
        return len(self._joint_types())

    def _joint_types(self, fitted=True):
        """The joint types X is read against: the fitted model's (fitted=False: as fit reads them, from the
        parameters), else joints, else robot's; none of them is an error (a log cannot tell R from P)."""
        if fitted and hasattr(self, "model_"):
            return self.model_.joints
        if self.joints is not None:
            return str(self.joints)
        if getattr(self, "robot", None) is not None:
            return (self.robot if isinstance(self.robot, Robot) else Robot.load(str(self.robot))).joint_types
        raise ValueError(_MISSING_JOINTS)

    def _inputs(self, X, joints=None):
        """X as a float64 matrix of 3n columns; a wrong width names the joints it was read against and the fix.
        joints: those a fit reads X against (_joint_types(fitted=False)); None: the fitted model's. A table
        with named columns (a pandas DataFrame) gives q1..qn, qd1..qdn, qdd1..qddn by name."""
        fitting = joints is not None
        if joints is None:
            joints = self._joint_types()
        n = len(joints)
        X = _as_matrix("X", _by_column_names("X", X, joints, ("q", "qd", "qdd")), one_row=False)
        if X.shape[1] != 3 * n:
            got = X.shape[1]
            if hasattr(self, "model_") and not fitting:
                fix = "the model was trained on these joints; give it rows of their q, qd, qdd"
            elif self.joints is None and getattr(self, "robot", None) is not None and got % 3 == 0 and got > 0:
                robot = self.robot.name if isinstance(self.robot, Robot) else self.robot
                fix = (f"they are the joints of robot={robot!r}, and {got} columns are {got // 3} joints: give the "
                       f"robot that made these rows")
            elif got % 3 == 0 and got > 0:
                fix = (f"set joints= to one R (revolute) or P (prismatic) per joint of your robot: {got} columns "
                       f"are {got // 3} joints, e.g. joints={'R' * (got // 3)!r}")
            else:
                fix = "X needs q, qd and qdd of every joint, in that order"
            raise ValueError(f"X has {got} columns (n_features={got}) but must have {3 * n} (q, qd, qdd of "
                             f"joints={joints!r}): {fix}")
        return X

    def _training_arrays(self, X, Y, joints):
        """(X, Y) checked against the joints and each other, in Fortran order for the C++ core."""
        n = len(joints)
        X = self._inputs(X, joints)
        self._y_is_1d = np.ndim(Y) == 1 and n == 1 and getattr(Y, "columns", None) is None
        Y = _as_matrix("Y", _by_column_names("Y", Y, joints, ("tau",)), n)
        if X.shape[0] != Y.shape[0]:
            raise ValueError(f"X has {X.shape[0]} rows but Y has {Y.shape[0]}")
        X, Y = np.asfortranarray(X), np.asfortranarray(Y)
        if np.isfinite(X).all():
            for message in _core.training_input_warnings(X, joints, "X"):
                warnings.warn(message, DataWarning, stacklevel=3)
        return X, Y

    def _check_fitted(self):
        if not hasattr(self, "model_"):
            raise NotFittedError(f"this {type(self).__name__} is not fitted yet; call fit(X, Y) first")

    def _as_fitted_y(self, torques):
        """Predictions in the shape of the y fit was given: (N,) for a 1-D y of one joint, else (N, n)."""
        return torques[:, 0] if getattr(self, "_y_is_1d", False) else torques

    def predict_one(self, x):
        """One sample (3n,) -> torques (n,): the allocation-free control-loop path."""
        self._check_fitted()
        x = _as_matrix("x", x, 3 * self.n_joints)
        if x.shape[0] != 1:
            raise ValueError("predict_one takes a single sample")
        return self.model_.predict_one(x[0])

    # rigid-body terms (estimators whose torque is affine in qdd; docs/method.md) --------
    def gravity(self, q):
        """Gravity torques g(q): (N, n) for positions q of shape (N, n)."""
        self._check_fitted()
        return self.model_.gravity(np.asfortranarray(_as_matrix("q", q, self.n_joints)))

    def inertia(self, q, symmetric=True):
        """Inertia matrices M(q): (N, n, n) for positions q of shape (N, n).

        Each joint's model learns one row of M; by default the result is the
        symmetric part of those rows (never farther from the true, symmetric M
        in Frobenius norm). symmetric=False gives the rows as learned."""
        self._check_fitted()
        return self.model_.inertia(np.asfortranarray(_as_matrix("q", q, self.n_joints)), symmetric)

    def coriolis(self, q, qd):
        """Coriolis and centrifugal torques C(q, qd) qd: (N, n)."""
        return self._velocity_terms(q, qd)[0]

    def friction(self, q, qd):
        """Friction torques (the part of the prediction odd in qd): (N, n)."""
        return self._velocity_terms(q, qd)[1]

    def _velocity_terms(self, q, qd):
        self._check_fitted()
        q = np.asfortranarray(_as_matrix("q", q, self.n_joints))
        qd = np.asfortranarray(_as_matrix("qd", qd, self.n_joints))
        return self.model_.velocity_terms(q, qd)

    def nmse(self, X, Y):
        """Per-joint nMSE of the predictions against Y."""
        self._check_fitted()
        Y = _as_matrix("Y", _by_column_names("Y", Y, self.model_.joints, ("tau",)), self.n_joints)
        return nmse(Y, self.predict(X).reshape(Y.shape))

    def score(self, X, Y, sample_weight=None):
        """The mean over joints of 1 - nMSE: higher is better, 1 is perfect, as
        scikit-learn's score (it equals the mean per-joint R^2)."""
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported")
        return float(np.mean(1.0 - self.nmse(X, Y)))

    def save(self, path):
        """Write the model in the same file format as `gipdyn train --out`."""
        self._check_fitted()
        self.model_.save(str(path))

    def __getstate__(self):
        parent = getattr(super(), "__getstate__", None)
        state = dict(parent() if parent is not None else self.__dict__)
        if "model_" in state:
            state["model_"] = state["model_"].to_bytes()
        if isinstance(state.get("robot"), Robot):
            raise ValueError("a model whose robot parameter is a Robot object cannot be pickled; pass its path")
        return state

    def __setstate__(self, state):
        state = dict(state)
        if "model_" in state:
            state["model_"] = self._MODEL_CLASS.from_bytes(state["model_"])
        parent = getattr(super(), "__setstate__", None)
        if parent is not None:
            parent(state)
        else:
            self.__dict__.update(state)


class InverseDynamicsGP(_JointTorqueRegressor):
    """Inverse dynamics learned with one Gaussian process per joint.

    Maps a robot's states X = [q, qd, qdd] (N, 3n) to its joint torques (N, n).
    The default is the library's: the GIP kernel, taught by LIP where that fits
    the log (teacher="auto"), hyperparameters by maximum marginal likelihood.
    Every parameter fills in the library's EstimatorOptions
    (estimator_options()), so the same parameters give the model
    `gipdyn train` gives with the matching options.

    Parameters
    ----------
    joints : str, optional
        One "R" (revolute) or "P" (prismatic) per joint, e.g. "RRPR". Required
        unless robot is given: a log cannot tell the two kinds apart (read_log
        returns those a log's sidecar records).
    model : str, optional
        The model: one of @KERNELS@ (those that need robot:
        @ROBOT_KERNELS@). None: the preset's, else "gip".
    optimizer : {"lbfgs", "adam"}, default "lbfgs"
        The hyperparameter optimiser.
    max_iter : int
        Safety cap on NLL evaluations (L-BFGS) or steps (Adam) per joint and start.
    restarts : int or None, default None
        Extra optimiser runs from perturbed starts; the lowest NLL is kept.
        None: the model's own (@RESTART_DEFAULTS@).
    random_state : int, RandomState or None, default 0
        Seeds restarts and teacher states. None is 0: every fit is seeded, and
        the same call gives the same model.
    scaling : {"standardize", "center", "none"}, default "standardize"
        Output scaling before the GP.
    min_noise : float, default 1e-8
        Noise-variance floor, as a fraction of the scaled output variance.
    n_jobs : int or None, default None
        Joints trained at once (None or -1: all cores, shared). Results do not
        depend on it.
    learning_rate : float, default 0.01
        Adam's learning rate.
    verbose : bool, default False
        Print the optimiser's progress.
    robot : str or Robot, optional
        The nominal robot of the pp and sp kernels ("scara", "ur10", a URDF or
        JSON file, or a Robot); also gives joints.
    robot_friction : bool, default False
        Friction columns in the nominal robot's regressor.
    mean : {"zero", "constant", "linear"}, default "zero"
        Prior mean of each joint's GP (linear in (q, qd, qdd)).
    prior : {"none", "lognormal"}, default "none"
        Maximum likelihood, or MAP with a log-normal prior on each
        hyperparameter of standard deviation prior_width.
    prior_width : float, default 2.0
    warm_start_rows : int, default 0
        GP and lip: optimise first on a constant-step subsample of this many
        rows, then the best on all rows (0: off).
    gradient_tolerance : float
        Converged when the projected NLL gradient per training row is below it.
    preset : {"default", "real"}, optional
        A named set of options; model and subsample given here override it.
        "real" (logs of real robots): the bounded GIP with friction
        ("gip-envelope+friction") on at most 1000 rows.
    subsample : int, optional
        Train on this many rows taken with a constant step (None: the preset's
        limit, else every row; 0: every row).
    inducing : int, default 0
        A sparse GP (variational bound) on this many inducing rows: for logs
        too long for the exact GP. 0: exact.
    distributed : bool, default False
        Spread each joint's N x N matrix over the MPI processes of the run
        (`mpirun -np P /usr/bin/python3 script.py`, every process with the same
        data; mpi_rank() == 0 is the one that should write).
    hyperparameter_rows : int, default 0
        Learn the hyperparameters on a constant-step subsample of this many
        rows, then condition the model on every row (0: all rows).
    hyperparameter_objective : {"bound", "exact"}, default "bound"
        With inducing and hyperparameter_rows: the subsample's variational
        bound or its exact NLL.
    teacher : {"auto", "lip", "chain", "none"} or None, default "auto"
        "lip" or "chain": fit that estimator on (X, Y), then learn from its
        torques at teacher_states states drawn from the box X spans (a GIP
        model that extrapolates like its teacher). "auto": "lip" where the
        library's rule says it applies (the gip kernel's exact GP on a short
        log) and the taught model fits (X, Y) as its teacher does; else learn
        from (X, Y). "none" or None: learn from (X, Y).
    teacher_states : int
        How many states the teacher labels.
    teacher_hyperparameter_rows : int
        The teacher learns its hyperparameters on this many logged rows (0: all).
    student_hyperparameter_rows : int
        The taught model learns its hyperparameters on this many drawn states
        (0: all; hyperparameter_rows above 0 wins).
    serial_chain : bool, default True
        The joints run from the base to the tip of one serial chain (the lip
        teacher's inertia entry ab then depends only on the joints after
        min(a, b)). False for joints in another order.
    start_screening : int or None, default None
        Every start runs this many NLL evaluations, then only the best goes on
        (0: every start to convergence). None: the model's own
        (@SCREENING_DEFAULTS@).

    Attributes
    ----------
    model_ : gipdyn._core.Model
        The fitted model (the library's; save() writes it).
    n_features_in_ : int
        3n.
    hyperparameters_ : list of dict
        Each joint's hyperparameters by name.
    log_marginal_likelihood_ : ndarray of shape (n,)
    training_report_ : list of dict
        Each joint's optimiser outcome (status, evaluations, NLL, noise share).
    teaching_ : str
        What became of the teacher: "taught", "student missed the log", "log
        too long", "teacher failed", "student failed" or "no teacher".
    teacher_ : LagrangianGP or None
        The fitted lip teacher, where there was one.
    teaching_check_ : dict or None
        The teacher's and the taught model's nMSE on (X, Y), "passed", a
        "warning" and "teacher_far_ahead" (joints the teacher fits ten times
        better; there it may be the more accurate model).
    teacher_report_, label_noise_std_, teaching_failure_
        The teacher's fit report, its residual per joint (the taught model's
        noise floor), and why a teacher or student failed.

    See Also
    --------
    LagrangianGP : LIP, one GP over every joint with energies.
    ContactDetector : contacts and external torques with a fitted model.

    Notes
    -----
    score() follows scikit-learn (higher is better): the mean over joints of
    1 - nMSE, the mean R^2; nmse() and neg_nmse_scorer give the nMSE itself.
    A table with named columns (a pandas DataFrame) is read by name: q1..qn,
    qd1..qdn, qdd1..qddn for X, tau1..taun for Y. A 1-D y (one joint) gives
    1-D predictions. The renamed parameters seed and threads are refused
    with their new names, random_state and n_jobs.

    Examples
    --------
    >>> import gipdyn
    >>> train = gipdyn.simulate("scara", samples=200, seed=1, dt=0.1)
    >>> model = gipdyn.InverseDynamicsGP(joints="RRPR").fit(train["X"], train["tau"])
    >>> model.predict(train["X"][:3]).shape
    (3, 4)
    """

    _MODEL_CLASS = _core.Model  # what model_ is, and how a pickle restores it

    def __init__(self, joints=None, model=None, optimizer="lbfgs", max_iter=_DEFAULTS.search.optimizer.max_iterations,
                 restarts=_DEFAULTS.search.restarts, random_state=0, scaling="standardize", min_noise=1e-8, n_jobs=None,
                 learning_rate=0.01, verbose=False, robot=None, robot_friction=False, mean="zero", prior="none",
                 prior_width=2.0, warm_start_rows=_DEFAULTS.gp.warm_start_rows,
                 gradient_tolerance=_DEFAULTS.search.gradient_tolerance_per_row, preset=None, subsample=None,
                 inducing=_DEFAULTS.sparse.inducing_points, distributed=False,
                 hyperparameter_rows=_DEFAULTS.search.hyperparameter_rows,
                 hyperparameter_objective=_DEFAULTS.sparse.hyperparameter_objective, teacher="auto",
                 teacher_states=_TEACHER_DEFAULTS.states,
                 teacher_hyperparameter_rows=_TEACHER_DEFAULTS.hyperparameter_rows,
                 student_hyperparameter_rows=_TEACHER_DEFAULTS.student_hyperparameter_rows,
                 serial_chain=_DEFAULTS.serial_chain,
                 start_screening=_DEFAULTS.search.start_screening_evaluations):
        self.joints = joints
        self.model = model
        self.optimizer = optimizer
        self.max_iter = max_iter
        self.restarts = restarts
        self.random_state = random_state
        self.scaling = scaling
        self.min_noise = min_noise
        self.n_jobs = n_jobs
        self.learning_rate = learning_rate
        self.verbose = verbose
        self.robot = robot
        self.robot_friction = robot_friction
        self.mean = mean
        self.prior = prior
        self.prior_width = prior_width
        self.warm_start_rows = warm_start_rows
        self.gradient_tolerance = gradient_tolerance
        self.preset = preset
        self.subsample = subsample
        self.inducing = inducing
        self.distributed = distributed
        self.hyperparameter_rows = hyperparameter_rows
        self.hyperparameter_objective = hyperparameter_objective
        self.teacher = teacher
        self.teacher_states = teacher_states
        self.teacher_hyperparameter_rows = teacher_hyperparameter_rows
        self.student_hyperparameter_rows = student_hyperparameter_rows
        self.serial_chain = serial_chain
        self.start_screening = start_screening

    def teacher_options(self, options=None):
        """The library's TeacherOptions for these parameters (options: estimator_options(), made when not given),
        or None without a teacher: the library's choose_teacher, as `gipdyn train --teacher` follows it."""
        choice = "none" if self.teacher is None else str(self.teacher)
        settings = TeacherOptions()
        settings.states = int(self.teacher_states)
        settings.hyperparameter_rows = int(self.teacher_hyperparameter_rows)
        settings.student_hyperparameter_rows = int(self.student_hyperparameter_rows)
        settings.seed = _seed(self.random_state)
        return _core.choose_teacher(choice, options if options is not None else self.estimator_options(), settings)

    def _search_options(self):
        """EstimatorOptions with the search every estimator learned by marginal likelihood shares."""
        o = EstimatorOptions()
        o.search.optimizer.kind = str(self.optimizer)
        o.search.optimizer.max_iterations = int(self.max_iter)
        o.search.optimizer.adam_learning_rate = float(self.learning_rate)
        if self.restarts is not None:
            o.search.restarts = int(self.restarts)
        o.search.seed = _seed(self.random_state)
        o.search.min_noise_fraction = float(self.min_noise)
        o.search.gradient_tolerance_per_row = float(self.gradient_tolerance)
        if self.start_screening is not None:
            o.search.start_screening_evaluations = int(self.start_screening)
        o.serial_chain = bool(self.serial_chain)
        return o

    def estimator_options(self):
        """The library's EstimatorOptions for these parameters (checked when fitting)."""
        o = self._search_options()
        # model=None: the preset's kernel, or the library's default without one.
        base = _core.preset_options(str(self.preset)) if self.preset is not None else EstimatorOptions()
        if self.model == _core.automatic_estimator_name():
            raise ValueError(f"model={self.model!r} (the choice by evidence of `gipdyn train --model auto`) may choose "
                             "a model this class cannot hold (the identified chain, a model per joint): use "
                             "InverseDynamics(model='auto'), or name a GP kernel")
        o.name = str(self.model) if self.model is not None else base.name
        o.gp.scaling = str(self.scaling)
        o.gp.mean = str(self.mean)
        o.search.threads = _threads(self.n_jobs)
        o.gp.warm_start_rows = int(self.warm_start_rows)
        o.sparse.inducing_points = int(self.inducing)
        o.search.hyperparameter_rows = int(self.hyperparameter_rows)
        o.sparse.hyperparameter_objective = str(self.hyperparameter_objective)
        if self.distributed:
            o.nll_backend = _core.distributed_backend()
            o.gp.keep_factor = False  # spread over the processes; predict(return_std=True) rebuilds it
        o.gp.prior = _core.parse_hyperparameter_prior(str(self.prior), float(self.prior_width))
        if self.robot is not None:
            o.robot = self.robot if isinstance(self.robot, Robot) else Robot.load(str(self.robot))
        o.robot_friction = bool(self.robot_friction)
        return o

    # fitting ---------------------------------------------------------------
    def fit(self, X, Y):
        joints = self._joint_types(fitted=False)  # once: robot= may name a file to load
        X, Y = self._training_arrays(X, Y, joints)
        rows = self._training_rows(X.shape[0])
        if rows is not None:
            X, Y = np.asfortranarray(X[rows]), np.asfortranarray(Y[rows])
        options = self.estimator_options()
        teacher = self.teacher_options(options)
        if teacher is not None and self.distributed:
            # teacher="auto" steps aside for a distributed fit (automatic_teaching_applies), as train's default does.
            raise ValueError("teacher is not distributed: fit without distributed=True, or with teacher=\"none\"")
        self._warn_about_a_long_exact_fit(options, teacher, X.shape[0], len(joints))
        fit = _core.fit(X, Y, joints, options, teacher, bool(self.verbose))
        self.model_ = fit["model"]
        self.teaching_ = fit["teaching"]
        # A taught model's rows are drawn states: partial_fit trains it again on the log, so the log is kept.
        self._taught_log = (X, Y) if self.teaching_ == "taught" else None
        # Set whether or not a teacher was chosen (teaching_ says which).
        self.teacher_ = None  # a fitted LagrangianGP when the teacher is LIP
        if fit["teacher"] is not None:
            self.teacher_ = LagrangianGP(joints=joints, friction=_estimator_row(teacher.name)["friction"])
            self.teacher_.model_ = fit["teacher"]
            self.teacher_._set_fitted_attributes()
        self.teacher_report_ = fit["teacher_report"]
        self.label_noise_std_ = fit["label_noise_std"]
        self.teaching_check_ = fit["teaching_check"]  # None unless a taught model was checked
        self.teaching_failure_ = fit["teaching_failure"]  # why, where teaching_ is "teacher failed" or "student failed"
        if self.teaching_ == "taught":  # a teaching not kept has no say in the model
            if fit["teacher"] is not None:
                _warn_unconverged_joints(fit["teacher"], f"teacher {teacher.name}: ")
            if self.teaching_check_["warning"]:
                warnings.warn(self.teaching_check_["warning"], TeachingWarning, stacklevel=2)
        self._set_fitted_attributes()
        _warn_unconverged_joints(self.model_)
        _warn_noisy_joints(self.model_)
        return self

    def _warn_about_a_long_exact_fit(self, options, teacher, rows, n_joints):
        # The library's rule, as `gipdyn train`'s note; the fix in this class's keywords.
        warning = _core.long_exact_fit_warning(_core.exact_hyperparameter_rows(options, teacher, rows, n_joints))
        if warning:
            warnings.warn(
                warning + ", so this fit may take hours. hyperparameter_rows=2000 learns them on a subsample and "
                "conditions the model on every row; inducing=500 makes every evaluation O(N M^2)", LongFitWarning,
                stacklevel=3)

    def partial_fit(self, X, Y, window=0, refit=None):
        """Online learning: add the rows of (X, Y) to the fitted model with its
        hyperparameters fixed (O(N^2) per row, a sparse model's O(M^2); the
        first call, on an unfitted estimator, is fit(X, Y)). window > 0 keeps
        only the newest window rows (exact models only); window=len(X)
        conditions the hyperparameters on X alone, e.g. those learned on a
        long, varied log carried to a short one (docs/results/training.md).

        Before conditioning, the new rows are checked against the model: how
        likely they are under it, against its own rows left out one at a
        time (update_check_ reports both per joint). Where they are far less
        likely, the hyperparameters were learned on other motions and no
        longer fit. refit=None (the default) then re-learns them on every
        kept row, as a new training starts; refit=True always re-learns them,
        starting from the current ones (the periodic refit of online
        learning); refit=False keeps them and raises ValueError where they no
        longer fit. A model taught by a teacher (teaching_ == "taught") has
        the teacher's drawn states for rows, not the log, and is not updated
        but trained again (fit) on the rows it was fitted on and the new ones
        (the newest window of them where window > 0): minutes, not
        milliseconds."""
        if not hasattr(self, "model_"):
            return self.fit(X, Y)
        if getattr(self, "_taught_log", None) is not None:
            old_X, old_Y = self._taught_log
            X_all = np.vstack([old_X, self._inputs(X)])
            Y_all = np.vstack([old_Y, _as_matrix("Y", _by_column_names("Y", Y, self.model_.joints, ("tau",)), self.n_joints)])
            if int(window) > 0:
                X_all, Y_all = X_all[-int(window):], Y_all[-int(window):]
            self.fit(X_all, Y_all)
            self.update_check_ = None
            return self
        n = self.n_joints
        X = self._inputs(X)
        Y = _as_matrix("Y", _by_column_names("Y", Y, self.model_.joints, ("tau",)), n)
        mode = "where-misfit" if refit is None else "always" if refit else "never"
        result = _core.update(self.model_, np.asfortranarray(X), np.asfortranarray(Y), int(window), False, mode,
                              self._search_options())
        self.model_ = result["model"]
        self.update_check_ = result["check"]
        if self.verbose and result["refit_report"]:
            print(result["refit_report"])
        self._set_fitted_attributes()
        return self

    def fit_trajectory(self, q, qd, qdd, tau):
        n = len(self._joint_types(fitted=False))
        q, qd, qdd = (_as_matrix(name, a, n) for name, a in (("q", q), ("qd", qd), ("qdd", qdd)))
        if not (q.shape == qd.shape == qdd.shape):
            raise ValueError("q, qd and qdd must have the same shape")
        return self.fit(np.hstack([q, qd, qdd]), tau)

    def _set_fitted_attributes(self):
        m = self.model_
        self.n_features_in_ = 3 * len(m.joints)
        self.hyperparameters_ = [dict(m.hyperparameters(j)) for j in range(len(m.joints))]
        self.log_marginal_likelihood_ = np.array([-m.nll(j) for j in range(len(m.joints))])
        self.training_report_ = list(m.training_report)

    # prediction ------------------------------------------------------------
    def predict(self, X, return_std=False):
        """Torques (N, n); with return_std also the latent standard deviations."""
        self._check_fitted()
        X = np.asfortranarray(self._inputs(X))
        if return_std:  # a loaded model builds its factors on the first call, inside model_, and keeps them
            return tuple(self._as_fitted_y(a) for a in self.model_.predict_with_std(X))
        return self._as_fitted_y(self.model_.predict(X))

    # persistence -----------------------------------------------------------
    @classmethod
    def load(cls, path):
        """Load a model written by `save` or by `gipdyn train`, with the parameters that trained it, as far as
        the file records them (docs/model-format.md, "options"): every one that shapes the model but robot
        (None), subsample and preset (None: the file's options are the preset's, overridden, and its rows
        those it was trained on). A teacher="auto" that never applies to these options comes back as "none",
        which trains the same model."""
        model = _core.Model.load(str(path))
        est = cls(joints=model.joints, model=model.kernel, **_recorded_parameters(cls, model))
        est.model_ = model
        est._set_fitted_attributes()
        return est


InverseDynamicsGP.__doc__ = InverseDynamicsGP.__doc__.replace("@RESTART_DEFAULTS@", _core.restart_defaults_summary()).replace(
    "@SCREENING_DEFAULTS@", _core.start_screening_defaults_summary()).replace(
    "@KERNELS@", ", ".join(f'"{r["name"]}"' for r in _core.estimator_table() if r["gp_kernel"])).replace(
    "@ROBOT_KERNELS@", ", ".join(f'"{r["name"]}"' for r in _core.estimator_table() if r["gp_kernel"] and r["needs_robot"]))



class InverseDynamics(_JointTorqueRegressor):
    """Inverse dynamics with any of the library's estimators, or the one its log's evidence chooses.

    The front door of the module: model names any estimator of the library's
    table (@ESTIMATORS@), or "auto", the choice by evidence: every candidate
    is fitted on the earlier rows and scored on a held-out later block, and
    the best (per joint, where another is far better on a joint) is refitted
    on every row. The same parameters give the model `gipdyn train` gives
    with the matching options. For predictive standard deviations, online
    updates and the hyperparameters, use InverseDynamicsGP or LagrangianGP.

    Parameters
    ----------
    joints : str, optional
        One "R" (revolute) or "P" (prismatic) per joint, e.g. "RRPR". Required
        unless robot is given.
    model : str, optional
        An estimator's name, or "auto" for the choice by evidence. None: the
        preset's, else the library's default ("gip", taught by LIP where that
        fits the log).
    preset : str, optional
        A named set of options for a kind of log (@PRESETS@), e.g. "real" for
        a real robot's log. Not with model="auto".
    robot : str or Robot, optional
        A robot description, for the estimators that need one (@ROBOT_ESTIMATORS@).
        Not with model="auto".
    teacher : {"auto", "none"} or str, default "auto"
        "auto": the library's rule (LIP teaches gip where that fits the log);
        "none"; or an estimator's name. model="auto" chooses its teachers itself.
    max_iter : int, optional
        Safety cap on NLL evaluations per joint and start. None: the preset's
        or the library's.
    restarts : int, optional
        Extra optimiser runs from perturbed starts. None: the preset's or the
        model's own (@RESTART_DEFAULTS@).
    random_state : int, RandomState or None, default 0
        Seeds every random process of the fit (restarts, teacher states,
        network initialisation). None is 0.
    n_jobs : int, optional
        Threads; None or -1: every core. The model does not depend on it.
    subsample : int, optional
        Train on this many rows at a constant step (0: every row). None: the
        preset's limit, every row without a preset.
    verbose : bool, default False
        Print progress and the brief report (and the comparison of
        model="auto") to stderr.

    Attributes
    ----------
    model_ : TrainedModel
        The fitted model: predict, predict_one, save, and the rigid-body terms
        where model_.gives_rigid_body_terms.
    chosen_ : str
        The estimator fitted: the chosen one for model="auto", or
        "chosen-per-joint" where joints chose different ones.
    selection_ : dict or None
        The comparison of model="auto" (the model file's "selection" block):
        each candidate's held-out nMSE per joint and mean; None otherwise.
    selection_report_ : str
        The comparison as text; "" without model="auto".
    report_ : str
        How the fit went, one line per joint.
    n_features_in_ : int
        3 n: q, qd and qdd of each joint.

    Examples
    --------
    >>> import gipdyn
    >>> train = gipdyn.simulate("scara", samples=300, seed=1, dt=0.05)
    >>> model = gipdyn.InverseDynamics(joints="RRPR", model="chain").fit(train["X"], train["tau"])
    >>> model.predict(train["X"][:3]).shape
    (3, 4)
    """

    _MODEL_CLASS = _core.TrainedModel  # what model_ is, and how a pickle restores it

    def __init__(self, joints=None, model=None, preset=None, robot=None, teacher="auto", max_iter=None,
                 restarts=None, random_state=0, n_jobs=None, subsample=None, verbose=False):
        self.joints = joints
        self.model = model
        self.preset = preset
        self.robot = robot
        self.teacher = teacher
        self.max_iter = max_iter
        self.restarts = restarts
        self.random_state = random_state
        self.n_jobs = n_jobs
        self.subsample = subsample
        self.verbose = verbose

    def _choosing(self):
        return self.model == _core.automatic_estimator_name()

    def estimator_options(self):
        """The library's EstimatorOptions for these parameters (checked when fitting); for model="auto", the
        options every candidate shares."""
        if self._choosing():
            for name in ("preset", "robot"):
                if getattr(self, name) is not None:
                    raise ValueError(f"{name}= chooses part of the model, and model='auto' chooses the whole model "
                                     f"by evidence: name a model to use {name}=, or drop it")
            if self.teacher not in ("auto", None):
                raise ValueError("teacher= chooses part of the model, and model='auto' chooses its teachers itself: "
                                 "name a model to use teacher=, or drop it")
        o = _core.preset_options(str(self.preset)) if self.preset is not None else EstimatorOptions()
        if self.model is not None and not self._choosing():
            _estimator_row(str(self.model))  # an unknown name lists the table's
            o.name = str(self.model)
        o.gp.keep_factor = False  # as `gipdyn train`: the factors are rebuilt where a variance is asked for
        if self.max_iter is not None:
            o.search.optimizer.max_iterations = int(self.max_iter)
        if self.restarts is not None:
            o.search.restarts = int(self.restarts)
        o.set_seed(_seed(self.random_state))
        o.search.threads = _threads(self.n_jobs)
        if self.robot is not None:
            o.robot = self.robot if isinstance(self.robot, Robot) else Robot.load(str(self.robot))
        return o

    def _teacher_settings(self, options):
        settings = TeacherOptions()
        settings.seed = options.search.seed
        return settings


    def fit(self, X, Y):
        """Fit the model (model="auto": choose it, then refit it) on the rows of (X, Y), in time order."""
        joints = self._joint_types(fitted=False)
        X, Y = self._training_arrays(X, Y, joints)
        rows = self._training_rows(X.shape[0])
        if rows is not None:
            X, Y = np.asfortranarray(X[rows]), np.asfortranarray(Y[rows])
        options = self.estimator_options()
        settings = self._teacher_settings(options)
        if self._choosing():
            fit = _core.fit_by_evidence(X, Y, joints, options, settings, bool(self.verbose))
        else:
            choice = "none" if self.teacher is None else str(self.teacher)
            teacher = _core.choose_teacher(choice, options, settings, any_estimator=True)
            fit = _core.fit_any(X, Y, joints, options, teacher, bool(self.verbose))
        self.model_ = fit["model"]
        self.selection_report_ = fit["selection_report"]
        self.report_ = fit["report"]
        self.teaching_ = fit["teaching"]
        self._set_fitted_attributes()
        for line in fit["convergence_warnings"]:  # as InverseDynamicsGP warns, from the library's lines
            warnings.warn(line, ConvergenceWarning, stacklevel=2)
        if fit["noise_warning"]:
            warnings.warn(fit["noise_warning"], NoiseWarning, stacklevel=2)
        return self

    def _set_fitted_attributes(self):
        self.n_features_in_ = 3 * len(self.model_.joints)
        self.chosen_ = self.model_.name
        record = self.model_.selection_record
        self.selection_ = json.loads(record) if record else None

    def predict(self, X, return_std=False):
        """Torques (N, n) for states X (N, 3n)."""
        self._check_fitted()
        if return_std:
            raise ValueError("InverseDynamics predicts means only: for a predictive standard deviation fit "
                             "InverseDynamicsGP or LagrangianGP")
        return self._as_fitted_y(self.model_.predict(np.asfortranarray(self._inputs(X))))


    @classmethod
    def load(cls, path):
        """Load any model file `gipdyn train` or a save() wrote, with the parameters the file records (model:
        "auto" where the choice by evidence made it)."""
        model = _core.TrainedModel.load(str(path))
        params = _recorded_parameters(cls, model)
        if model.selection_record:  # the choice by evidence chose the teachers too
            params.pop("teacher", None)
            params["model"] = _core.automatic_estimator_name()
        else:
            params["model"] = model.name
        est = cls(joints=model.joints, **params)
        est.model_ = model
        est.selection_report_ = ""
        est.report_ = ""
        est.teaching_ = ""
        est._set_fitted_attributes()
        return est


InverseDynamics.__doc__ = InverseDynamics.__doc__.replace("@RESTART_DEFAULTS@", _core.restart_defaults_summary()).replace(
    "@ESTIMATORS@", ", ".join(f'"{r["name"]}"' for r in _core.estimator_table())).replace(
    "@ROBOT_ESTIMATORS@", ", ".join(f'"{r["name"]}"' for r in _core.estimator_table() if r["needs_robot"])).replace(
    "@PRESETS@", ", ".join(f'"{name}"' for name in _core.preset_names()))

class LagrangianGP(InverseDynamicsGP):
    """LIP: one GP over the torques of every joint, built from energies.

    Priors on the kinetic and potential energy give the torques through the
    Lagrange equations (docs/method.md section 11). Besides torques, gravity,
    inertia and Coriolis terms it estimates the energies: kinetic_energy(X)
    and potential_energy(q) (up to a constant). Its system is (N n) x (N n):
    train it on a few hundred rows, or learn the hyperparameters on a few
    hundred (hyperparameter_rows) and condition on a few thousand.

    Parameters
    ----------
    joints : str, optional
        One "R" or "P" per joint; required (a log cannot tell them apart).
    optimizer, max_iter, restarts, random_state, min_noise, learning_rate, verbose, gradient_tolerance
        As InverseDynamicsGP's.
    hyperparameter_rows : int, default 0
        Learn the hyperparameters on a constant-step subsample of this many
        rows, then condition on every row (0: all rows).
    friction : bool, default False
        Each joint's smooth friction and torque offset beside the energies
        (the estimator lip+friction).
    serial_chain : bool, default True
        False for joints not ordered from the base to the tip of one serial
        chain: every inertia entry may then depend on every joint.
    start_screening : int or None, default None
        Every start (three starting noises plus the restarts) runs this many
        NLL evaluations, then only the one with the lowest NLL goes on (0:
        every start to convergence). None: the library's.

    Attributes
    ----------
    model_ : gipdyn._core.LagrangianModel
    n_features_in_ : int
    hyperparameters_ : dict
        The shared hyperparameters by name.
    noise_variances_ : ndarray of shape (n,)
        Each joint's noise variance, in torque units squared.
    training_report_ : list of dict

    Examples
    --------
    >>> import gipdyn
    >>> train = gipdyn.simulate("scara", samples=100, seed=1, dt=0.2)
    >>> lip = gipdyn.LagrangianGP(joints="RRPR").fit(train["X"], train["tau"])
    >>> lip.potential_energy(train["q"][:2]).shape
    (2,)
    """

    _MODEL_CLASS = _core.LagrangianModel
    _RENAMED_PARAMETERS = _RENAMED_SEARCH_PARAMETERS

    def __init__(self, joints=None, optimizer="lbfgs", max_iter=_DEFAULTS.search.optimizer.max_iterations,
                 restarts=_DEFAULTS.search.restarts, random_state=0, min_noise=1e-8, learning_rate=0.01, verbose=False,
                 gradient_tolerance=_DEFAULTS.search.gradient_tolerance_per_row,
                 hyperparameter_rows=_DEFAULTS.search.hyperparameter_rows, friction=False,
                 serial_chain=_DEFAULTS.serial_chain,
                 start_screening=_DEFAULTS.search.start_screening_evaluations):
        self.joints = joints
        self.friction = friction
        self.serial_chain = serial_chain
        self.start_screening = start_screening
        self.optimizer = optimizer
        self.max_iter = max_iter
        self.restarts = restarts
        self.random_state = random_state
        self.min_noise = min_noise
        self.learning_rate = learning_rate
        self.verbose = verbose
        self.gradient_tolerance = gradient_tolerance
        self.hyperparameter_rows = hyperparameter_rows

    def estimator_options(self):
        """The library's EstimatorOptions for these parameters (checked when fitting)."""
        o = self._search_options()
        o.name = _core.lagrangian_estimator_name(bool(self.friction))
        o.search.hyperparameter_rows = int(self.hyperparameter_rows)
        return o

    def fit(self, X, Y):
        joints = self._joint_types(fitted=False)
        X, Y = self._training_arrays(X, Y, joints)
        self.model_ = _core.train_lagrangian(X, Y, joints, self.estimator_options(), bool(self.verbose))
        self._set_fitted_attributes()
        _warn_unconverged_joints(self.model_)
        _warn_noisy_joints(self.model_)
        return self

    @property
    def partial_fit(self):
        """LIP has no online updates, so the estimator has no partial_fit (hasattr is False, as
        scikit-learn's checks expect): fit() on the new data."""
        raise AttributeError("LagrangianGP has no online updates (partial_fit); fit() on the new data")

    def _set_fitted_attributes(self):
        m = self.model_
        self.n_features_in_ = 3 * len(m.joints)
        self.hyperparameters_ = dict(m.hyperparameters)
        self.noise_variances_ = np.asarray(m.noise_variances)
        self.training_report_ = list(m.training_report)

    def predict(self, X, return_std=False):
        """Torques (N, n); with return_std also the latent standard deviations
        (the first such call factorises the (N n)^2 training covariance once)."""
        self._check_fitted()
        X = np.asfortranarray(self._inputs(X))
        mean = self._as_fitted_y(self.model_.predict(X))
        if not return_std:
            return mean
        return mean, self._as_fitted_y(self.model_.predict_std(X))  # a loaded model builds its factor once, inside model_

    def predict_one(self, x):
        return self.predict(np.atleast_2d(x))[0]

    def kinetic_energy(self, X):
        """Kinetic energy (N,) at states X of shape (N, 2n) (q, qd) or (N, 3n)."""
        self._check_fitted()
        X = _as_matrix("X", X)
        return self.model_.kinetic_energy(np.asfortranarray(X))

    def potential_energy(self, q):
        """Potential energy (N,) at positions q of shape (N, n), up to an additive constant."""
        self._check_fitted()
        return self.model_.potential_energy(np.asfortranarray(_as_matrix("q", q, self.n_joints)))

    @classmethod
    def load(cls, path):
        """Load a lip model written by `save` or by `gipdyn train --model lip`, with the parameters that trained
        it, as InverseDynamicsGP.load does."""
        model = _core.LagrangianModel.load(str(path))
        est = cls(joints=model.joints, friction=_estimator_row(model.estimator)["friction"],
                  **_recorded_parameters(cls, model))
        est.model_ = model
        est._set_fitted_attributes()
        return est



def read_log(path, joints=None, mat_variable=None, torques=True, columns=None):
    """Read a robot log as the command line does: a CSV with columns q1..qn,
    qd1..qdn, qdd1..qddn and tau1..taun (any order and separator;
    docs/reference/log-format.md), or, with mat_variable, that matrix of a MATLAB .mat file
    (columns by position). columns says what a CSV calls gipdyn's columns
    when it has other names: a dict of patterns, {i} the joint's number from 1
    and {i0} from 0, e.g. {"q": "position_{i0}", "qd": "velocity_{i0}",
    "tau": "effort_{i0}"} for a ROS joint_states export (quantities not named
    keep gipdyn's names), or the path of a JSON file of them, as the command
    line's --columns. joints is the joint-type string ("RRPR"); None:
    the types the CSV's PATH.json sidecar records (`gipdyn simulate` writes
    them). Returns a dict of NumPy arrays q, qd, qdd, X (= [q, qd, qdd]), tau
    (None when torques=False) and tau_true (None unless the file has
    tau1_true..), and joints. Errors (a missing column, NaN, a wrong joint
    count) raise GipdynError."""
    if joints is None:
        joints = None if mat_variable else _core.sidecar_joint_types(str(path))
        if joints is None:
            raise ValueError(f"joints is required for '{path}': one 'R' (revolute) or 'P' (prismatic) per joint, which "
                             "a log cannot tell apart (a log written by gipdyn simulate records them in its .json sidecar)")
    if isinstance(columns, dict):
        columns = ",".join(f"{quantity}={pattern}" for quantity, pattern in columns.items())
    return _core.read_log(str(path), str(joints), mat_variable or "", bool(torques), columns or "")


def simulate(robot="scara", samples=2000, seed=0, noise=0.01, dt=0.01, perturb_kinematics=False, friction=False,
             contacts=0, contact_size=None, contact_duration=None, contact_joint=0):
    """Simulate a robot ("scara", "ur10", a .urdf/.json path, or a Robot) on a
    random sum-of-sinusoids trajectory. Returns a dict of NumPy arrays q, qd,
    qdd, X (= [q, qd, qdd]), tau (noisy), tau_true, and metadata (a dict).

    With contacts > 0, that many constant external torques (contact_size: a
    fraction of the joint's torque range; contact_duration in seconds;
    contact_joint 1..n, or 0 for a joint drawn for each) act on the robot
    while a PD controller keeps it on the trajectory; the dict then also holds
    external, the true external torque (N, n), for ContactDetector."""
    if isinstance(robot, str):
        robot = Robot.load(robot)
    o = SimulationOptions()
    o.samples = int(samples)
    o.seed = int(seed)
    o.noise_std = float(noise)
    o.dt = float(dt)
    o.perturb_kinematics = bool(perturb_kinematics)
    o.friction = bool(friction)
    c = o.contacts
    c.count = int(contacts)
    if contact_size is not None:
        c.size = float(contact_size)
    if contact_duration is not None:
        c.duration = float(contact_duration)
    c.joint = int(contact_joint)
    o.contacts = c
    out = _core.simulate(robot, o)
    out["metadata"] = json.loads(out["metadata"])
    return out


_CONTACT_DEFAULTS = ContactOptions()


class ContactDetector:
    """Contacts and external joint torques from measured torques and a fitted model.

    A robot in contact obeys M(q) qdd + C(q, qd) qd + g(q) = tau + tau_ext; the
    fitted model stands in for the left-hand side, and tau_ext, the torque the
    environment applies to each joint, is estimated from the measured tau.

    Parameters
    ----------
    model : InverseDynamics, InverseDynamicsGP or LagrangianGP, fitted
        The model of the robot without contact. A model without a predictive
        standard deviation (an InverseDynamics model of another family than
        the GPs and LIP) needs calibrate() before detect().
    sample_time : float
        The rows' sampling period in seconds.
    method : {"residual", "momentum"}, default "residual"
        residual: tau_ext = f(q, qd, qdd) - tau, for any model. momentum: the
        generalized-momentum observer, which needs no acceleration but a
        model with an inertia matrix (gip, gip-friction, pp, lip, ...).
    false_alarm_rate : float, default 1e-6
        Probability, per row and joint, that a contact-free residual exceeds
        the threshold: the threshold is its two-sided Gaussian quantile times
        the residual's standard deviation.
    min_duration : float, default 0.005
        Seconds the residual must stay above the threshold before a contact is
        flagged (at least one row).
    momentum_gain : float, default 0 (automatic)
        The observer's gain in 1/s, at most 1 / sample_time; 0 gives a time
        constant of 10 ms or two rows, whichever is longer.
    predictive_variance : bool, default True
        Whether the threshold holds the model's predictive standard deviation;
        False: the noise alone, faster on long logs and large models.

    The residual's standard deviation combines the model's predictive standard
    deviation with the noise it learned, or with the noise measured by
    calibrate() on contact-free rows of the robot.
    """

    def __init__(self, model, sample_time, method="residual", false_alarm_rate=_CONTACT_DEFAULTS.false_alarm_rate,
                 min_duration=_CONTACT_DEFAULTS.min_duration, momentum_gain=_CONTACT_DEFAULTS.momentum_gain,
                 predictive_variance=_CONTACT_DEFAULTS.predictive_variance):
        if not isinstance(model, (InverseDynamics, InverseDynamicsGP)):
            raise TypeError("ContactDetector needs a fitted InverseDynamics, InverseDynamicsGP or LagrangianGP, not "
                            f"{type(model).__name__}")
        model._check_fitted()
        o = ContactOptions()
        o.method = method
        o.sample_time = float(sample_time)
        o.false_alarm_rate = float(false_alarm_rate)
        o.min_duration = float(min_duration)
        o.momentum_gain = float(momentum_gain)
        o.predictive_variance = bool(predictive_variance)
        o.validate()
        self.model = model
        self.options = o
        self._detector = _core.ContactDetector(model.model_, o)

    def _rows(self, X, tau):
        n = self.model.n_joints
        return (np.asfortranarray(_as_matrix("X", X, 3 * n)), np.asfortranarray(_as_matrix("tau", tau, n)))

    def calibrate(self, X, tau):
        """Measures each joint's noise on consecutive contact-free rows (not the
        training rows: a model fits its own rows too well). Returns self."""
        self._detector.calibrate(*self._rows(X, tau))
        return self

    def detect(self, X, tau):
        """Runs over consecutive rows of one log (X: (N, 3n), tau: (N, n)).
        Returns a ContactDetection: external_torque, threshold, contact (0/1)
        and margin (|external| / threshold), each (N, n), and brief_report()."""
        return self._detector.detect(*self._rows(X, tau))

    def external_torque(self, X, tau):
        """The method's estimate of the external torque alone, (N, n)."""
        return self._detector.external_torque(*self._rows(X, tau))


def neighbour_consistency(X, tau, X_test=None, tau_test=None, radius=0.1, min_separation_rows=100,
                          use_accelerations=False, max_queries=5000, joints=None):
    """Is the torque a function of the logged state? Pairs rows that visit the
    same state (q, qd, and qdd with use_accelerations, each divided by its
    standard deviation over X, at most radius apart) and compares their torques.
    Without a test log: rows of X at least min_separation_rows apart; with one:
    each test row's nearest row of X. Returns a dict: status ("ok" or
    "too-few-pairs"), message, queries, pairs, neighbour_nmse and correlation
    per joint. Within one log half the neighbour nMSE is about the noise share;
    a test log far above the training log's value follows another function of
    the state (docs/results/real-robots.md, `gipdyn inspect`). joints (e.g. "RRPR"):
    revolute positions are compared on the circle, q and q + 2 pi being one
    state, as the kernels see them; None: positions as logged."""
    o = NeighbourConsistencyOptions()
    if joints is not None:
        o.joints = str(joints)
    o.radius = float(radius)
    o.min_separation_rows = int(min_separation_rows)
    o.use_accelerations = bool(use_accelerations)
    o.max_queries = int(max_queries)
    X = _as_matrix("X", X)
    tau = _as_matrix("tau", tau)
    if (X_test is None) != (tau_test is None):
        raise ValueError("give both X_test and tau_test, or neither")
    if X_test is None:
        return _core.neighbour_consistency(X, tau, o)
    return _core.neighbour_consistency(X, tau, _as_matrix("X_test", X_test), _as_matrix("tau_test", tau_test), o)
