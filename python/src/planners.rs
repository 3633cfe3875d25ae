//! Planners across the language line: a Python object planning in the episode's loop
//! (`PythonPlanner`, through `run_with_planner` and `run_cli`), and the built-in planners as
//! Python objects (`BuiltinPlanner`) with the same `plan(observation, map)`, so a Python
//! planner can wrap or compare with them. Plans and failures cross as `Plan` and
//! `PlanFailure` objects that keep every field, so a wrapped planner's decisions reach the
//! controller unchanged.

use crate::arrays::Frame;
use crate::map::Map;
use crate::{to_py, words_error};
use autonomy::explore::{Decision, Planner, Recovery};
use autonomy::map::GaussianMap;
use autonomy::splat::Rasteriser;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatloop::episode::{PlannerContext as Context, PlannerKind};
use splatloop::robot::{Pose2, UnicycleCommand};
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

fn pose(p: &Pose2) -> (f64, f64, f64) {
    (p.x, p.y, p.theta)
}

/// A plan: `commands` [(v, w), ...] one per `period` seconds, the `states` (x, y, theta) the
/// unicycle model predicts (the start first), the planner's `target` pose if it has one, its
/// `score`, the `candidates` it compared and `commit` (seconds the host follows it before
/// asking again). Returned from `plan`, it is driven exactly as the planner made it.
#[pyclass(frozen, module = "splatloop._splatloop")]
pub struct Plan {
    pub plan: autonomy::explore::Plan,
}

#[pymethods]
impl Plan {
    #[getter]
    fn commands(&self) -> Vec<(f64, f64)> {
        self.plan.commands.iter().map(|u| (u.v, u.w)).collect()
    }

    #[getter]
    fn period(&self) -> f64 {
        self.plan.period
    }

    #[getter]
    fn states(&self) -> Vec<(f64, f64, f64)> {
        self.plan.states.iter().map(pose).collect()
    }

    #[getter]
    fn target(&self) -> Option<(f64, f64, f64)> {
        self.plan.target.as_ref().map(pose)
    }

    #[getter]
    fn score(&self) -> f64 {
        self.plan.score
    }

    #[getter]
    fn candidates(&self) -> usize {
        self.plan.candidates
    }

    #[getter]
    fn commit(&self) -> f64 {
        self.plan.commit
    }

    /// `plan["commands"]`, as for a plan written as a dict.
    fn __getitem__<'py>(slf: &Bound<'py, Self>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        match key {
            "commands" | "period" | "states" | "target" | "score" | "candidates" | "commit" => {
                slf.getattr(key)
            }
            other => Err(pyo3::exceptions::PyKeyError::new_err(format!(
                "{other:?}: a plan has commands, period, states, target, score, candidates and commit"
            ))),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "<splatloop plan of {} commands, {} s each, score {:.3}>",
            self.plan.commands.len(),
            self.plan.period,
            self.plan.score
        )
    }
}

/// No plan, and why: `kind` (EmptyMap, StartInCollision, NoCollisionFreeCandidate,
/// NoCandidateClearOfUnseen, GoalUnreachable, BoxedIn), `message`, and the host's `recovery` (turn_in_place or back_off).
/// Returned from `plan`, the host runs that recovery, as for a built-in planner.
#[pyclass(frozen, module = "splatloop._splatloop")]
pub struct PlanFailure {
    pub failure: autonomy::explore::PlanFailure,
}

#[pymethods]
impl PlanFailure {
    #[getter]
    fn kind(&self) -> &'static str {
        self.failure.kind()
    }

    #[getter]
    fn message(&self) -> String {
        self.failure.to_string()
    }

    #[getter]
    fn recovery(&self) -> &'static str {
        match self.failure.recovery() {
            Recovery::TurnInPlace => "turn_in_place",
            Recovery::BackOff { .. } => "back_off",
        }
    }

    fn __repr__(&self) -> String {
        format!("<splatloop plan failure {}: {}>", self.kind(), self.failure)
    }
}

/// A decision as Python sees it: a `Plan`, a `PlanFailure`, or a string (done, and why).
pub fn decision_to_py(py: Python<'_>, decision: Decision) -> PyResult<PyObject> {
    Ok(match decision {
        Decision::Go(plan) => Py::new(py, Plan { plan })?.into_any(),
        Decision::Fail(failure) => Py::new(py, PlanFailure { failure })?.into_any(),
        Decision::Done(reason) => reason.into_pyobject(py)?.into_any().unbind(),
        Decision::Abort(reason) => return Err(PyRuntimeError::new_err(reason)),
    })
}

/// What a planner is built with: the camera's `K`, `width`, `height` and `range`, the
/// episode's `seed`, the think `period` and `settled_omega` (RT-GuIDE's settled motion). A
/// Python planner's `start(context)` gets it before the first frame; a wrapped built-in
/// planner needs it passed on.
#[pyclass(frozen, module = "splatloop._splatloop")]
#[derive(Clone, Copy)]
pub struct PlannerContext {
    pub context: Context,
}

#[pymethods]
impl PlannerContext {
    #[getter(K)]
    fn intrinsics(&self) -> [[f64; 3]; 3] {
        let k = &self.context.intrinsics;
        [[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]]
    }

    #[getter]
    fn width(&self) -> u32 {
        self.context.intrinsics.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.context.intrinsics.height
    }

    #[getter]
    fn range(&self) -> f64 {
        self.context.range
    }

    #[getter]
    fn seed(&self) -> u64 {
        self.context.seed
    }

    #[getter]
    fn period(&self) -> f64 {
        self.context.period
    }

    #[getter]
    fn settled_omega(&self) -> f64 {
        self.context.settled_omega
    }
}

/// A built-in planner (rtguide, fbe or agslam) as a Python object with a Python planner's
/// methods: `start(context)`, `observe(frame)`, `plan(observation, map)`. Made by
/// `splatloop.planners.make`; built at `start`, when the camera is known.
#[pyclass(unsendable, module = "splatloop._splatloop")]
pub struct BuiltinPlanner {
    kind: PlannerKind,
    options: splatloop::episode::PlannerOptions,
    planner: Option<Box<dyn Planner>>,
}

impl BuiltinPlanner {
    fn built(&mut self) -> PyResult<&mut Box<dyn Planner>> {
        let name = self.kind.name();
        self.planner.as_mut().ok_or_else(|| {
            PyRuntimeError::new_err(format!(
                "the {name} planner is built at start(context): a planner that wraps it passes its own start(context) on"
            ))
        })
    }
}

#[pymethods]
impl BuiltinPlanner {
    /// `name` (rtguide, fbe, agslam) with `splatloop run`'s planner flags in `words`.
    #[new]
    fn new(name: &str, words: Vec<String>) -> PyResult<Self> {
        let kind: PlannerKind = name.parse().map_err(PyValueError::new_err)?;
        if kind == PlannerKind::Survey {
            return Err(PyValueError::new_err(
                "the survey knows the world's floor plan, so only an episode builds it: Env(planner=\"survey\") or env.plan(\"survey\")",
            ));
        }
        let config = splatloop::commands::run_config_from_words(words).map_err(words_error)?;
        Ok(BuiltinPlanner {
            kind,
            options: config.planner_options,
            planner: None,
        })
    }

    /// The planner's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.kind.name()
    }

    /// Builds the planner for the episode's camera (a new one each time: a new episode).
    fn start(&mut self, context: &PlannerContext) -> PyResult<()> {
        let planner =
            splatloop::planners::build_explorer(self.kind, &self.options, context.context)
                .map_err(to_py)?;
        self.planner = Some(planner);
        Ok(())
    }

    /// Takes in one camera frame.
    fn observe(&mut self, frame: &Bound<'_, Frame>, map: &Bound<'_, Map>) -> PyResult<()> {
        let frame = frame.get();
        self.built()?.observe(&frame.observation(), &map.get().map);
        Ok(())
    }

    /// Plans from `observation["start"]` on `map`: a `Plan`, a `PlanFailure` or a string.
    fn plan(
        &mut self,
        py: Python<'_>,
        observation: &Bound<'_, PyAny>,
        map: &Bound<'_, Map>,
    ) -> PyResult<PyObject> {
        let (x, y, theta): (f64, f64, f64) = observation.get_item("start")?.extract()?;
        let decision = self.built()?.plan(&map.get().map, Pose2 { x, y, theta });
        decision_to_py(py, decision)
    }

    /// The planner's settings, as metrics.json records them (JSON).
    fn settings(&mut self) -> PyResult<String> {
        Ok(self.built()?.settings().to_string())
    }
}

/// A planner written in Python, in the episode's loop: every think period `obj.plan(observation,
/// map)` with `observation` = {"start": (x, y, theta), "time": t} and `map` a `Map`; it returns
/// a `Plan` or a `PlanFailure` (a built-in planner's, unchanged), a dict with `commands`
/// ([(v, w), ...], one per `period` seconds, default 1), a string to end the episode with that
/// reason, or `None` for no plan (the host turns in place). `obj.observe(frame, map)`, when
/// defined, sees every frame (a `Frame`); `obj.start(context)`, when defined, is called once
/// before the first. Its decisions go through the same controller as the built-in planners'.
struct PythonPlanner {
    obj: Py<PyAny>,
    class: String,
    /// `python-CLASS`, as a sweep's folders and tables name it.
    name: String,
    engine: Rc<RefCell<Option<Arc<Rasteriser>>>>,
    max_range: f64,
    /// Whether `obj.observe` exists (asked once).
    observes: bool,
    /// The first exception the object raised; the episode ends on it and it is raised again.
    error: Rc<RefCell<Option<PyErr>>>,
}

impl PythonPlanner {
    fn map<'py>(&self, py: Python<'py>, map: &GaussianMap) -> PyResult<Bound<'py, Map>> {
        let engine = self
            .engine
            .borrow()
            .clone()
            .unwrap_or_else(|| Arc::new(Rasteriser::Cpu));
        Bound::new(
            py,
            Map {
                map: map.clone(),
                engine,
                max_range: self.max_range,
            },
        )
    }

    fn decide(&self, py: Python<'_>, map: &GaussianMap, start: Pose2) -> PyResult<Decision> {
        use autonomy::explore::{Plan as RustPlan, PlanFailure as Failure};
        let observation = PyDict::new(py);
        observation.set_item("start", pose(&start))?;
        let answer = self
            .obj
            .call_method1(py, "plan", (observation, self.map(py, map)?))?;
        let answer = answer.bind(py);
        if answer.is_none() {
            return Ok(Decision::Fail(Failure::GoalUnreachable));
        }
        if let Ok(plan) = answer.downcast::<Plan>() {
            return Ok(Decision::Go(plan.get().plan.clone()));
        }
        if let Ok(failure) = answer.downcast::<PlanFailure>() {
            return Ok(Decision::Fail(failure.get().failure.clone()));
        }
        if let Ok(reason) = answer.extract::<String>() {
            return Ok(Decision::Done(reason));
        }
        if !answer.is_instance_of::<PyDict>() {
            return Err(PyTypeError::new_err(format!(
                "plan() returned a {}; return a dict with commands (and period), a Plan, a PlanFailure, a string (done) or None",
                answer.get_type().name()?
            )));
        }
        let commands: Vec<(f64, f64)> = answer.get_item("commands")?.extract()?;
        let period: f64 = match answer.get_item("period") {
            Ok(p) => p.extract()?,
            Err(_) => 1.0,
        };
        let limits = autonomy::drive::DriveLimits::default();
        if !(period.is_finite() && period > 0.0) || commands.is_empty() {
            return Err(PyValueError::new_err(format!(
                "a plan needs commands and a positive period; got {} commands, period {period}",
                commands.len()
            )));
        }
        let mut drive = Vec::with_capacity(commands.len());
        for (v, w) in commands {
            let u = UnicycleCommand { v, w };
            if !(v.is_finite() && w.is_finite() && limits.admits(u)) {
                return Err(PyValueError::new_err(format!(
                    "plan command ({v}, {w}) is outside the drive's limits (0 <= v <= {} m/s, |w| <= {} rad/s)",
                    limits.max_forward, limits.max_turn
                )));
            }
            drive.push(u);
        }
        Ok(Decision::Go(RustPlan::driven(start, drive, period)))
    }

    fn fail(&self, e: PyErr) -> Decision {
        let reason = format!("the Python planner raised: {e}");
        *self.error.borrow_mut() = Some(e);
        Decision::Abort(reason)
    }
}

impl Planner for PythonPlanner {
    fn name(&self) -> &str {
        &self.name
    }

    fn settings(&self) -> serde_json::Value {
        serde_json::json!({ "class": self.class })
    }

    fn observe(&mut self, observation: &autonomy::explore::Observation<'_>, map: &GaussianMap) {
        if !self.observes || self.error.borrow().is_some() {
            return;
        }
        Python::with_gil(|py| {
            let frame = Frame {
                rgb: observation.rgb.to_vec(),
                depth: observation.depth.to_vec(),
                camera: *observation.camera,
                max_range: observation.max_range,
                robot: observation.robot,
            };
            let outcome = self
                .map(py, map)
                .and_then(|map| self.obj.call_method1(py, "observe", (frame, map)));
            if let Err(e) = outcome {
                *self.error.borrow_mut() = Some(e);
            }
        });
    }

    fn plan(&mut self, map: &GaussianMap, start: Pose2) -> Decision {
        if let Some(e) = self.error.borrow().as_ref() {
            return Decision::Abort(format!("the Python planner raised: {e}"));
        }
        Python::with_gil(|py| match self.decide(py, map, start) {
            Ok(decision) => decision,
            Err(e) => self.fail(e),
        })
    }
}

/// The bridge for `planner`, started with the episode's context; its exception cell.
struct Bridge {
    engine: Rc<RefCell<Option<Arc<Rasteriser>>>>,
    error: Rc<RefCell<Option<PyErr>>>,
}

impl Bridge {
    fn new() -> Self {
        Bridge {
            engine: Rc::new(RefCell::new(None)),
            error: Rc::new(RefCell::new(None)),
        }
    }

    /// Makes the planner once the episode knows its camera: `planner.start(context)` first.
    fn factory(
        &self,
        planner: Py<PyAny>,
        max_range: f64,
    ) -> splatloop::commands::PlannerFactory<'static> {
        let engine = self.engine.clone();
        let error = self.error.clone();
        Box::new(move |context: &Context| {
            Python::with_gil(|py| {
                let bound = planner.bind(py);
                let class = bound
                    .get_type()
                    .qualname()
                    .map(|n| n.to_string())
                    .unwrap_or_else(|_| "?".to_owned());
                let started = (|| -> PyResult<bool> {
                    if bound.hasattr("start")? {
                        bound.call_method1("start", (PlannerContext { context: *context },))?;
                    }
                    bound.hasattr("observe")
                })();
                let observes = match started {
                    Ok(observes) => observes,
                    Err(e) => {
                        let detail = format!("its start(context) raised: {e}");
                        *error.borrow_mut() = Some(e);
                        return Err(splatloop::SimError::InvalidArgument {
                            what: "Python planner",
                            detail,
                        });
                    }
                };
                Ok(Box::new(PythonPlanner {
                    obj: planner.clone_ref(py),
                    name: format!("python-{class}"),
                    class,
                    engine: engine.clone(),
                    max_range,
                    observes,
                    error: error.clone(),
                }) as Box<dyn Planner>)
            })
        })
    }

    /// The planner's own exception, if it raised one (it is the error the caller sees).
    fn raised(&self) -> Option<PyErr> {
        self.error.borrow_mut().take()
    }
}

/// Runs a whole episode (`splatloop run`'s flags in `words`) with `planner`, a Python object,
/// deciding every think period; writes the folder and returns metrics.json as a JSON string.
/// An exception the planner raised ends the episode (still written) and is raised again.
#[pyfunction]
pub fn run_with_planner(words: Vec<String>, planner: Py<PyAny>) -> PyResult<String> {
    let config = splatloop::commands::run_config_from_words(words).map_err(words_error)?;
    let bridge = Bridge::new();
    let episode = splatloop::episode::Episode::with_planner(
        &config,
        bridge.factory(planner, config.sensor.max_range),
    );
    let episode = match episode {
        Ok(episode) => episode,
        Err(e) => return Err(bridge.raised().unwrap_or_else(|| to_py(e))),
    };
    *bridge.engine.borrow_mut() = Some(episode.engine());
    let metrics = splatloop::episode::run_to_end(episode, &mut |_| {});
    if let Some(e) = bridge.raised() {
        return Err(e);
    }
    let metrics = metrics.map_err(to_py)?;
    serde_json::to_string(&metrics).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// `splatloop run WORDS` with `planner` deciding (what the binary's `--planner python:...`
/// starts): its progress bar, signal handling (Ctrl-C still writes the episode), summary and
/// errors as the binary prints them. Returns the exit code.
#[pyfunction]
pub fn run_cli(words: Vec<String>, planner: Py<PyAny>) -> PyResult<u8> {
    let bridge = Bridge::new();
    let max_range = splatloop::camera::SensorConfig::default().max_range;
    let engine = bridge.engine.clone();
    let factory = bridge.factory(planner, max_range);
    let outcome = splatloop::commands::run_words_with_planner(words, factory, &mut |episode| {
        *engine.borrow_mut() = Some(episode.engine());
    });
    if let Some(e) = bridge.raised() {
        return Err(e);
    }
    Ok(match outcome {
        Ok(code) => code.unwrap_or(0),
        Err(e) => {
            eprintln!("error: {e:#}");
            1
        }
    })
}
