"""kinem: planar-mechanism kinematics in Cartesian coordinates (Nikravesh, Ch. 4).

    import kinem
    case = kinem.load("cases/slider_crank.toml")   # or kinem.load_dict({...})
    model = kinem.compile(case)
    result = kinem.solve(model)                    # SolveResult
    result.trajectory["slider.x"]                  # numpy array over result.trajectory.t

Versions: ``kinem.__version__``, ``kinem --version``.
"""
__version__ = "0.1.0"   # as pyproject.toml's version (tests/test_front_door.py holds them equal)

from .analysis import Data, acceleration, factorize, position, velocity
from .case import load, load_dict, loads
from .errors import AnalysisError, ConvergenceError, InputError, KinemError, KinemWarning, SingularError
from .front import solve
from .model import Model, compile
from .notebook import animate, plot
from .options import Options
from .parameters import Parameter, parameters
from .result import OUTPUTS, SolveResult, Status, Trajectory
from .sensitivity import Sensitivity, sensitivity
from .spec import Body, Case, Constraint, Point
from .sweep import Sweep, sweep

__all__ = [
    "__version__", "load", "loads", "load_dict", "compile", "solve", "position", "velocity", "acceleration",
    "factorize", "Data", "Options", "Model", "Case", "Body", "Point", "Constraint", "SolveResult", "Trajectory",
    "Status", "OUTPUTS", "sweep", "Sweep", "plot", "animate", "parameters", "Parameter", "sensitivity", "Sensitivity",
    "KinemError", "KinemWarning", "InputError", "AnalysisError", "ConvergenceError", "SingularError",
]
