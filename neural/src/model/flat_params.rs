//! Flat views of a module's float parameters, in the module's visit order: saving and loading
//! weights, and Reptile's meta-gradient (theta - theta', registered as the gradient of an
//! outer optimiser).

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::{Tensor, TensorData};

struct Flatten<'a>(&'a mut Vec<f32>);

impl ModuleVisitor for Flatten<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let data = param.val().into_data().convert::<f32>();
        self.0.extend_from_slice(data.as_slice::<f32>().expect("f32 tensor"));
    }
}

/// Every float parameter, concatenated in visit order.
pub fn flatten<M: Module>(module: &M) -> Vec<f32> {
    let mut out = Vec::with_capacity(module.num_params());
    module.visit(&mut Flatten(&mut out));
    out
}

struct Load<'a> {
    flat: &'a [f32],
    offset: usize,
}

impl ModuleMapper for Load<'_> {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let (id, old, mapper) = param.consume();
        let shape = old.shape();
        let n = shape.num_elements();
        let values = self.flat[self.offset..self.offset + n].to_vec();
        self.offset += n;
        let require_grad = old.is_require_grad();
        let mut value = Tensor::<D>::from_data(TensorData::new(values, shape), &old.device());
        if require_grad {
            value = value.require_grad();
        }
        Param::from_mapped_value(id, value, mapper)
    }
}

/// Replace every float parameter by the next values of `flat` (same order as [`flatten`]),
/// keeping parameter ids, devices and trainability. `flat` must have exactly `num_params`.
pub fn load_flat<M: Module>(module: M, flat: &[f32]) -> crate::error::Result<M> {
    let expected = module.num_params();
    if flat.len() != expected {
        return Err(crate::error::Error::invalid(format!(
            "{} weights given, the network has {expected}",
            flat.len()
        )));
    }
    let mut loader = Load { flat, offset: 0 };
    Ok(module.map(&mut loader))
}

struct Difference<'a> {
    adapted: &'a [f32],
    offset: usize,
    grads: GradientsParams,
}

impl ModuleVisitor for Difference<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let value = param.val();
        // Gradients live on the parameter's device without autodiff (CPU or GPU).
        let device = value.device().without_autodiff();
        let shape = value.shape();
        let n = shape.num_elements();
        let data = value.into_data().convert::<f32>();
        let theta = data.as_slice::<f32>().expect("f32 tensor");
        let diff: Vec<f32> = theta
            .iter()
            .zip(&self.adapted[self.offset..self.offset + n])
            .map(|(a, b)| a - b)
            .collect();
        self.offset += n;
        self.grads
            .register(param.id, Tensor::<D>::from_data(TensorData::new(diff, shape), &device));
    }
}

/// Reptile's meta-gradient: theta - theta' for every parameter of `module` (theta), with
/// theta' given flat (the task-adapted copy, or the mean of several). An optimiser stepping
/// along it moves theta towards theta'.
pub fn reptile_gradients<M: Module>(module: &M, adapted: &[f32]) -> GradientsParams {
    assert_eq!(adapted.len(), module.num_params(), "adapted parameters do not match the module");
    let mut v = Difference { adapted, offset: 0, grads: GradientsParams::new() };
    module.visit(&mut v);
    v.grads
}

struct GradientVisitor<'a> {
    grads: &'a GradientsParams,
    out: Vec<f32>,
}

impl ModuleVisitor for GradientVisitor<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let n = param.val().shape().num_elements();
        match self.grads.get::<D>(param.id) {
            Some(g) => self.out.extend_from_slice(
                g.into_data().convert::<f32>().as_slice::<f32>().expect("f32 tensor"),
            ),
            None => self.out.extend(std::iter::repeat_n(0.0, n)),
        }
    }
}

/// Every parameter's gradient in a container, flat in visit order (zeros where a parameter has
/// none): the training path's layout, for comparing it with burn's autodiff.
pub fn flat_gradients<M: Module>(module: &M, grads: &GradientsParams) -> Vec<f32> {
    let mut v = GradientVisitor { grads, out: Vec::with_capacity(module.num_params()) };
    module.visit(&mut v);
    v.out
}
