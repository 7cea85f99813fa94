//! Model folders as a checked format: what a weight file must satisfy before a policy acts
//! from it. Every learner's model loader goes through here (MADE-Net's and DME-DRL's).
//!
//! - **Digest**: training writes the XXH3-128 of each weight file into `model.toml`
//!   (`digests`); loading recomputes it, so a flipped byte is refused instead of playing.
//!   (XXH3 guards against corruption, not against an adversary: a model folder is code-like
//!   input a user chose to run.)
//! - **Shapes** (feature `burn`): weights are applied with burn's fallible `try_load_record`,
//!   so sizes in `model.toml` that disagree with the weights are an error, not a panic
//!   (`checked_weights`).
//! - **Finite** (feature `burn`): a NaN or ∞ parameter is refused by name
//!   (`first_non_finite`).
//!
//! ```
//! let d = madenet_harness::integrity::digest(b"weights");
//! assert_eq!(d.len(), 32);
//! assert!(madenet_harness::integrity::check_digest(b"weights", &d).is_ok());
//! assert!(madenet_harness::integrity::check_digest(b"weighTs", &d).is_err());
//! ```

use crate::error::TrainError;
#[cfg(feature = "burn")]
use burn::module::{Module, ModuleVisitor, Param};
#[cfg(feature = "burn")]
use burn::tensor::Tensor;

/// The digest `model.toml` records for a weight file: XXH3-128, 32 lowercase hex digits.
pub fn digest(bytes: &[u8]) -> String {
    format!("{:032x}", xxhash_rust::xxh3::xxh3_128(bytes))
}

/// Whether `bytes` are the file whose digest is `expected` ([`digest`]).
pub fn check_digest(bytes: &[u8], expected: &str) -> Result<(), String> {
    let got = digest(bytes);
    if got == expected.to_ascii_lowercase() {
        Ok(())
    } else {
        Err(format!(
            "the file's digest is {got}, model.toml records {expected}: the file is damaged or is not the one trained"
        ))
    }
}

/// The first parameter of `module` holding a NaN or ∞, as `path.to.param`, if any.
#[cfg(feature = "burn")]
pub fn first_non_finite<M: Module>(module: &M) -> Option<String> {
    let mut v = FiniteCheck::default();
    module.visit(&mut v);
    v.found
}

#[cfg(feature = "burn")]
#[derive(Default)]
struct FiniteCheck {
    path: Vec<String>,
    found: Option<String>,
}

#[cfg(feature = "burn")]
impl ModuleVisitor for FiniteCheck {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.path.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if self.found.is_some() {
            return;
        }
        let data = param.val().into_data().convert::<f32>();
        let finite = data
            .as_slice::<f32>()
            .map(|s| s.iter().all(|x| x.is_finite()))
            .unwrap_or(true);
        if !finite {
            self.found = Some(self.path.join("."));
        }
    }
}

/// Refuses a model whose `digests` do not match its weight files (a count that differs is a
/// bad `digests` field); warns (at each load) when the folder predates digests.
pub fn check_digests(
    digests: &[String],
    files: &[(String, Vec<u8>)],
    label: &str,
) -> Result<(), TrainError> {
    if digests.is_empty() {
        tracing::warn!("{label}: no `digests` (written before madenet recorded them): the weights' integrity is not checked");
        return Ok(());
    }
    if digests.len() != files.len() {
        return Err(TrainError::Config {
            path: label.to_string(),
            message: format!(
                "field `digests`: {} digests for {} weight files",
                digests.len(),
                files.len()
            ),
        });
    }
    for (d, (name, bytes)) in digests.iter().zip(files) {
        crate::integrity::check_digest(bytes, d).map_err(|message| TrainError::Config {
            path: format!("{label}: {name}"),
            message,
        })?;
    }
    Ok(())
}

/// A network loaded from weight file `name` of the model `label`: weights that do not fit the
/// sizes (`sizes` names the fields that set them) or hold a NaN/∞ are refused by name.
#[cfg(feature = "burn")]
pub fn checked_weights<M: burn::module::Module>(
    loaded: Result<M, burn::store::RecordError>,
    name: &str,
    label: &str,
    sizes: &str,
) -> Result<M, TrainError> {
    let net = loaded.map_err(|e| TrainError::Config {
        path: format!("{label}: {name}"),
        message: format!("the weights do not fit the sizes in model.toml ({sizes}): {e}"),
    })?;
    match crate::integrity::first_non_finite(&net) {
        Some(param) => Err(TrainError::Config {
            path: format!("{label}: {name}"),
            message: format!("parameter `{param}` holds NaN or infinite values"),
        }),
        None => Ok(net),
    }
}

#[cfg(all(test, feature = "burn"))]
mod tests {
    use super::*;
    use burn::nn::LinearConfig;

    #[test]
    fn a_nan_or_infinite_parameter_is_found_by_its_path() {
        let dev = burn::tensor::Device::flex();
        let mut lin = LinearConfig::new(2, 2).init(&dev);
        assert_eq!(first_non_finite(&lin), None);
        for bad in [f32::NAN, f32::INFINITY] {
            lin.weight = Param::from_tensor(Tensor::from_data([[0.5, bad], [0.0, 1.0]], &dev));
            assert_eq!(first_non_finite(&lin).as_deref(), Some("weight"), "{bad}");
        }
    }
}
