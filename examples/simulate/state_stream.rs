//! `simulate --fixed-dt DT --steps K --json`: the particle state (`x`, `v`, `sigma`, `F`)
//! written straight to the output as it is serialised, so that printing it holds no second
//! copy of the state in memory.

use mpm_dt::nd::{SolverNd, Tensor, Vector};
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::Value;
use std::io::Write;

/// Writes the run's final state into an output stream.
pub type StateWriter = Box<dyn FnOnce(&mut dyn Write) -> std::io::Result<()>>;

/// A writer of `s`'s committed state, taking the solver along.
pub fn writer<const D: usize>(s: SolverNd<D>) -> StateWriter
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>> + mpm_dt::controller::StandardLimits<D>,
{
    Box::new(move |out| {
        let view = s.view();
        let state = State {
            x: view.x,
            v: view.v,
            sigma: view.sigma,
            f: view.f,
        };
        serde_json::to_writer(out, &state).map_err(std::io::Error::other)
    })
}

/// Prints `summary` (a JSON object) with a `state` member written by `state`.
pub fn print_with_state(summary: &Value, state: StateWriter) -> std::io::Result<()> {
    let text = summary.to_string();
    let head = text.strip_suffix('}').unwrap_or(&text);
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let sep = if head.ends_with('{') { "" } else { "," };
    write!(out, "{head}{sep}\"state\":")?;
    state(&mut out)?;
    writeln!(out, "}}")?;
    out.flush()
}

/// The particle fields, serialised as nested lists without building them.
struct State<'a, const D: usize> {
    x: &'a [Vector<D>],
    v: &'a [Vector<D>],
    sigma: &'a [Tensor<D>],
    f: &'a [Tensor<D>],
}

impl<const D: usize> Serialize for State<'_, D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(4))?;
        map.serialize_entry("x", &Vectors(self.x))?;
        map.serialize_entry("v", &Vectors(self.v))?;
        map.serialize_entry("sigma", &Tensors(self.sigma))?;
        map.serialize_entry("F", &Tensors(self.f))?;
        map.end()
    }
}

struct Vectors<'a, const D: usize>(&'a [Vector<D>]);

impl<const D: usize> Serialize for Vectors<'_, D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().map(|x| x.as_slice()))
    }
}

struct Tensors<'a, const D: usize>(&'a [Tensor<D>]);

impl<const D: usize> Serialize for Tensors<'_, D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().map(|t| Rows(*t)))
    }
}

/// A tensor as its list of rows.
struct Rows<const D: usize>(Tensor<D>);

impl<const D: usize> Serialize for Rows<D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..D).map(|r| Row(&self.0, r)))
    }
}

/// Row `r` of a tensor.
struct Row<'a, const D: usize>(&'a Tensor<D>, usize);

impl<const D: usize> Serialize for Row<'_, D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..D).map(|c| self.0[(self.1, c)]))
    }
}
