//! The ordered field program of an object and the per-sample context its functions see.
//!
//! An object's fields are defined by a list of [`Instr`]uctions (`vlSet`, `vlFunction`, `vlMap`)
//! run in issue order at every sample point; each sees what the previous ones wrote. A field
//! function receives a [`Sample`]: the point in object space, its world position, the ten field
//! values, and the mask of fields that the function's `vlFunction` call named — writes outside that
//! mask are ignored (the paper's Figure 5 sphere writes all fields and is used for one). Every
//! written value is clamped to [0, 1] and NaN becomes 0, so no callback can put a NaN into a pixel.
//!
//! This module does not know about rays or the C interface: the C layer wraps C function pointers
//! into closures of the types below.

use crate::data::{Dataset, Filter, GradientFilter};
use crate::error::{err, Error, ErrorCode, Result};
use crate::model::mapping::Mapping;
pub(crate) use crate::num::clamp_field;
pub(crate) use crate::num::clamp_fields;
use crate::types::{DatasetId, Fields, FIELD_COUNT};
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

/// A field function: runs at a sample point and writes fields through [`Sample::set`].
pub type FieldFn = Arc<dyn Fn(&mut Sample<'_>) + Send + Sync>;

/// A normal function: receives the current normal (to rewrite in place) and the sample, whose
/// fields and position it may read.
pub type NormalFn = Arc<dyn Fn(&mut [f32; 3], &mut Sample<'_>) + Send + Sync>;

/// The datasets of a library, by id, shared without copies.
pub type Datasets = BTreeMap<DatasetId, Arc<Dataset>>;

/// What a sample can reach besides its own point: the library's datasets (for `vlSample`), the
/// interpolation filter of the object being evaluated, and its children (for `vlChild*`).
#[derive(Clone, Debug, Default)]
pub(crate) struct SampleEnv {
    pub(crate) datasets: Arc<Datasets>,
    pub(crate) filter: Filter,
    pub(crate) children: Arc<Vec<Child>>,
}

impl SampleEnv {
    /// An environment with these datasets and filter, and no children.
    #[cfg(test)]
    pub(crate) fn new(datasets: Arc<Datasets>, filter: Filter) -> SampleEnv {
        SampleEnv {
            datasets,
            filter,
            children: Arc::default(),
        }
    }
}

/// A child object as its parent's field and normal functions see it: its own program and
/// environment, placed in the parent's object space.
#[derive(Clone)]
pub struct Child {
    pub(crate) program: Vec<Instr>,
    /// Parent object space → child object space.
    pub(crate) to_child: glam::DMat4,
    /// World → child object space (for world-space normals).
    pub(crate) world_to_child: glam::DMat4,
    pub(crate) box_min: glam::DVec3,
    pub(crate) box_max: glam::DVec3,
    pub(crate) env: SampleEnv,
}

impl fmt::Debug for Child {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Child")
            .field("program", &self.program)
            .field("to_child", &self.to_child)
            .finish()
    }
}

impl Child {
    fn inside(&self, q: glam::DVec3) -> bool {
        q.cmpge(self.box_min).all() && q.cmple(self.box_max).all()
    }

    /// All fields of the child at child-space point `q` (0 outside its boundary).
    pub(crate) fn fields_at(&self, q: glam::DVec3, world: [f64; 3]) -> [f32; FIELD_COUNT] {
        if !self.inside(q) {
            return [0.0; FIELD_COUNT];
        }
        let mut s = Sample::with_env(q.as_vec3().to_array(), world, &self.env);
        run(&self.program, &mut s);
        s.fields
    }
}

/// `vlSample`: dataset `id` at dataset coordinates `p` with `filter`.
pub(crate) fn sample_dataset(
    datasets: &Datasets,
    id: DatasetId,
    p: [f32; 3],
    filter: Filter,
) -> Result<f32> {
    // (The id is the first parameter: an unknown one is reported before a bad point.)
    let d = datasets
        .get(&id)
        .ok_or_else(|| Error::new(ErrorCode::BadId, format!("vlSample: no dataset {id}")))?;
    if p.iter().any(|v| !v.is_finite()) {
        return err(
            ErrorCode::BadValue,
            format!("vlSample: point {p:?} is not finite"),
        );
    }
    Ok(d.sample(p, filter))
}

/// What a sample's callback may do (the sample scope of the state machine).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum SampleRole {
    /// A field function: may write the fields of its mask.
    Field,
    /// A normal function: may read fields, may not write them.
    Normal,
    /// A spatial transfer function: may move the point, may not write fields.
    Spatial,
}

/// The context of one sample point, handed to field and normal functions.
pub struct Sample<'a> {
    /// The point in object space (the unit cube is [0, 1]^3).
    pub(crate) p: [f32; 3],
    /// The point in world space.
    pub(crate) world: [f64; 3],
    /// The ten field values, in bit order of [`Fields`].
    pub(crate) fields: [f32; FIELD_COUNT],
    /// The fields the running function may write.
    pub(crate) mask: Fields,
    pub(crate) role: SampleRole,
    /// Whether the sample is one of a normal's central differences: its dataset instructions
    /// then read through the BC-spline of their gradient filter where that is cubic.
    pub(crate) for_gradient: bool,
    env: Option<&'a SampleEnv>,
    /// The fields of the children read at this sample.
    children: std::cell::RefCell<ChildFields>,
}

/// The fields of the children a sample has read, by child and point: a child that several
/// instructions read at one point (a union of its opacity, then a blend of its colours) runs
/// its program once there, so that nested objects cost what their number does, not two to the
/// power of their depth. A few are looked up in a list, more in a hash map.
#[derive(Default)]
struct ChildFields {
    few: Vec<(i32, [u32; 3], [f32; FIELD_COUNT])>,
    many: Option<std::collections::HashMap<ChildKey, [f32; FIELD_COUNT]>>,
}

/// A child read at a sample: its number and the bits of the sample's object-space point.
type ChildKey = (i32, [u32; 3]);

/// Children a sample looks up in a list before it files them in a hash map.
const FEW_CHILDREN: usize = 8;

impl ChildFields {
    fn get(&self, key: ChildKey) -> Option<[f32; FIELD_COUNT]> {
        match &self.many {
            Some(map) => map.get(&key).copied(),
            None => self.few.iter().find(|e| (e.0, e.1) == key).map(|e| e.2),
        }
    }

    fn insert(&mut self, key: ChildKey, fields: [f32; FIELD_COUNT]) {
        if let Some(map) = &mut self.many {
            map.insert(key, fields);
        } else if self.few.len() < FEW_CHILDREN {
            self.few.push((key.0, key.1, fields));
        } else {
            let mut map: std::collections::HashMap<_, _> =
                self.few.drain(..).map(|(i, p, f)| ((i, p), f)).collect();
            map.insert(key, fields);
            self.many = Some(map);
        }
    }
}

impl Sample<'static> {
    /// A fresh sample at object point `p` and world point `world`, all fields 0, with no
    /// datasets in reach, as a field function whose `vlFunction` named all ten fields sees it:
    /// [`Sample::set`] writes every field it names. For calling a field function, or vlaux's
    /// and `cvg`'s functions, outside a render (a test of one's own function, say).
    pub fn new(p: [f32; 3], world: [f64; 3]) -> Sample<'static> {
        Sample {
            p,
            world,
            fields: [0.0; FIELD_COUNT],
            mask: Fields::ALL,
            role: SampleRole::Field,
            for_gradient: false,
            env: None,
            children: Default::default(),
        }
    }
}

impl<'a> Sample<'a> {
    /// A fresh sample that can reach the datasets and filter of `env`.
    pub(crate) fn with_env(p: [f32; 3], world: [f64; 3], env: &'a SampleEnv) -> Sample<'a> {
        Sample {
            p,
            world,
            fields: [0.0; FIELD_COUNT],
            mask: Fields::NONE,
            role: SampleRole::Field,
            for_gradient: false,
            env: Some(env),
            children: Default::default(),
        }
    }

    /// `vlSpatial`: moves the sample point (object space); later instructions see the new
    /// point. Only a spatial transfer function may do this (`BadScope` elsewhere); a
    /// non-finite point is `BadValue`, and the point stays where it was.
    pub fn set_position(&mut self, p: [f32; 3]) -> Result<()> {
        if self.role != SampleRole::Spatial {
            return err(
                ErrorCode::BadScope,
                "only a spatial transfer function may move the point",
            );
        }
        if p.iter().any(|v| !v.is_finite()) {
            return err(
                ErrorCode::BadValue,
                format!("spatial function moved the point to {p:?}"),
            );
        }
        self.p = p;
        Ok(())
    }

    fn child(&self, i: i32) -> Result<&'a Child> {
        let children = self.env.map(|e| &e.children[..]).unwrap_or(&[]);
        if i < 1 || i as usize > children.len() {
            return err(
                ErrorCode::BadIndex,
                format!("child {i} of an object with {} children", children.len()),
            );
        }
        Ok(&children[i as usize - 1])
    }

    fn child_point(&self, c: &Child) -> glam::DVec3 {
        let p = glam::DVec3::new(self.p[0] as f64, self.p[1] as f64, self.p[2] as f64);
        c.to_child.transform_point3(p)
    }

    /// `vlChildCount`: the number of children of the object being evaluated.
    pub fn child_count(&self) -> usize {
        self.env.map_or(0, |e| e.children.len())
    }

    /// `vlChildHit`: whether the current point lies inside child `i`'s (transformed) boundary;
    /// children count from 1 in declaration order.
    pub fn child_hit(&self, i: i32) -> Result<bool> {
        let c = self.child(i)?;
        Ok(c.inside(self.child_point(c)))
    }

    /// `vlChildField`: field `field` of child `i`, evaluated with the child's own program at the
    /// current point in the child's space (0 outside the child's boundary).
    pub fn child_field(&self, i: i32, field: Fields) -> Result<f32> {
        let index = field.validate_single()?;
        Ok(self.child_fields(i)?[index])
    }

    /// All ten fields of child `i` at the current point (what the CVG operators combine). A
    /// child is evaluated once at a point, however many instructions read it there.
    pub fn child_fields(&self, i: i32) -> Result<[f32; FIELD_COUNT]> {
        let c = self.child(i)?;
        let key = (i, self.p.map(f32::to_bits));
        if let Some(fields) = self.children.borrow().get(key) {
            return Ok(fields);
        }
        let fields = c.fields_at(self.child_point(c), self.world);
        self.children.borrow_mut().insert(key, fields);
        Ok(fields)
    }

    /// `vlChildNormal` (normal functions only): the world-space normal of child `i` at the current
    /// point, −∇F of the child by central differences in its object space (offset 10⁻³ of its
    /// cube), taken to world space; zero where the gradient vanishes.
    pub fn child_normal(&self, i: i32) -> Result<[f32; 3]> {
        self.may_take_child_normals()?;
        let c = self.child(i)?;
        let q = self.child_point(c);
        let h = 1e-3;
        let mut g = glam::DVec3::ZERO;
        for axis in 0..3 {
            let mut e = glam::DVec3::ZERO;
            e[axis] = h;
            let f = |q: glam::DVec3| c.fields_at(q, self.world)[9] as f64;
            g[axis] = (f(q + e) - f(q - e)) / (2.0 * h);
        }
        let gw = glam::DMat3::from_mat4(c.world_to_child).transpose() * g;
        Ok((-gw)
            .try_normalize()
            .unwrap_or(glam::DVec3::ZERO)
            .as_vec3()
            .to_array())
    }

    /// `vlSample` inside a field function: dataset `id` at dataset coordinates `p`, with the
    /// interpolation the object captured.
    pub fn dataset(&self, id: DatasetId, p: [f32; 3]) -> Result<f32> {
        match self.env {
            Some(env) => sample_dataset(&env.datasets, id, p, env.filter),
            None => err(ErrorCode::BadId, format!("vlSample: no dataset {id}")),
        }
    }

    /// The point in object space.
    pub fn position(&self) -> [f32; 3] {
        self.p
    }

    /// The point in world space (`vlPosition`), each coordinate the nearest f32: finite, a
    /// coordinate beyond f32's range (a scene scaled past 3.4·10³⁸, whose points f64 holds) at
    /// ±`f32::MAX`, a NaN (none the renderer makes) 0.
    pub fn world_position(&self) -> [f32; 3] {
        self.world.map(|c| {
            if c.is_nan() {
                0.0
            } else {
                c.clamp(-f32::MAX as f64, f32::MAX as f64) as f32
            }
        })
    }

    /// The role of the function now running.
    pub fn role(&self) -> SampleRole {
        self.role
    }

    /// The current value of field number `index` (0 = opacity … 9 = geometry); for a field
    /// named by its mask, [`Sample::field`].
    ///
    /// # Panics
    ///
    /// If `index` is not below [`FIELD_COUNT`], as indexing [`Sample::values`] with it would.
    pub fn value(&self, index: usize) -> f32 {
        self.fields[index]
    }

    /// All ten field values.
    pub fn values(&self) -> [f32; FIELD_COUNT] {
        self.fields
    }

    /// `vlField`: the current value of one field, named by a single-bit mask; `BadField` for
    /// a mask that names no field, several, or has a bit that names none.
    pub fn field(&self, field: Fields) -> Result<f32> {
        match field.single_index() {
            Some(i) => Ok(self.fields[i]),
            None => err(ErrorCode::BadField, "vlField needs exactly one field"),
        }
    }

    /// `vlSet` inside a field function: writes `value` (clamped to [0, 1], NaN → 0) to the fields
    /// of `fields` that the running function's `vlFunction` call named; others are left alone.
    /// `BadField` (and nothing written) for an empty mask or one with a bit that names no
    /// field, as `Library::set` gives.
    pub fn set(&mut self, fields: Fields, value: f32) -> Result<()> {
        self.may_set()?;
        if fields == Fields::NONE {
            return err(ErrorCode::BadField, "vlSet: empty field mask");
        }
        if fields.bits() & !Fields::ALL.bits() != 0 {
            return err(
                ErrorCode::BadField,
                format!(
                    "vlSet: field mask {:#x} has bits that name no field",
                    fields.bits()
                ),
            );
        }
        self.write(fields & self.mask, value);
        Ok(())
    }

    /// Whether `vlSet` is legal in this function (a field function's; not a normal or a
    /// spatial function's): `VL_BADSCOPE` otherwise, checked before its arguments.
    pub fn may_set(&self) -> Result<()> {
        if self.role != SampleRole::Field {
            return err(
                ErrorCode::BadScope,
                "vlSet is legal only inside field functions (not normal or spatial ones)",
            );
        }
        Ok(())
    }

    /// Whether `vlChildNormal` is legal in this function (a normal function's):
    /// `VL_BADSCOPE` otherwise, checked before its arguments.
    pub fn may_take_child_normals(&self) -> Result<()> {
        if self.role != SampleRole::Normal {
            return err(
                ErrorCode::BadScope,
                "vlChildNormal is legal only in normal functions",
            );
        }
        Ok(())
    }

    #[inline]
    pub(crate) fn write(&mut self, fields: Fields, value: f32) {
        let v = clamp_field(value);
        let mut bits = fields.bits() & Fields::ALL.bits();
        while bits != 0 {
            self.fields[bits.trailing_zeros() as usize] = v;
            bits &= bits - 1;
        }
    }
}

impl fmt::Debug for Sample<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Sample")
            .field("p", &self.p)
            .field("world", &self.world)
            .field("fields", &self.fields)
            .finish()
    }
}

/// One instruction of an object's field program.
#[derive(Clone)]
pub enum Instr {
    /// `vlSet` in an object: assign a constant (already clamped) to fields.
    Set {
        /// The fields written.
        fields: Fields,
        /// The value, in [0, 1].
        value: f32,
    },
    /// `vlFunction`: run a field function that may write `fields`.
    Function {
        /// The fields the function may write.
        fields: Fields,
        /// The function.
        f: FieldFn,
    },
    /// `vlDataset`: write a dataset's interpolated value to fields.
    Dataset {
        /// The fields written.
        fields: Fields,
        /// The dataset, shared.
        data: Arc<Dataset>,
        /// The interpolation captured at `vlDataset`.
        filter: Filter,
        /// The gradient filter captured at `vlDataset`.
        gradient: GradientFilter,
    },
    /// `vlSpatial`: a spatial transfer function that may move the point.
    Spatial {
        /// The function.
        f: FieldFn,
    },
    /// `vlMap`: targets = Φ(value of source field), output `output` (from 0).
    Map {
        /// The fields written.
        targets: Fields,
        /// Index of the source field.
        source: usize,
        /// The transfer function, captured at `vlMap`.
        mapping: Arc<Mapping>,
        /// The output column, counted from 0.
        output: usize,
    },
}

impl Instr {
    /// The fields this instruction may write.
    pub fn writes(&self) -> Fields {
        match self {
            Instr::Set { fields, .. }
            | Instr::Function { fields, .. }
            | Instr::Dataset { fields, .. } => *fields,
            Instr::Map { targets, .. } => *targets,
            Instr::Spatial { .. } => Fields::NONE,
        }
    }
}

impl fmt::Debug for Instr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Instr::Set { fields, value } => write!(f, "Set({fields:?}, {value})"),
            Instr::Function { fields, f: func } => {
                write!(
                    f,
                    "Function({fields:?}, {:p})",
                    Arc::as_ptr(func) as *const ()
                )
            }
            Instr::Spatial { f: func } => {
                write!(f, "Spatial({:p})", Arc::as_ptr(func) as *const ())
            }
            Instr::Dataset {
                fields,
                data,
                filter,
                gradient,
            } => write!(
                f,
                "Dataset({fields:?}, {:p}, {filter:?}, {gradient:?})",
                Arc::as_ptr(data)
            ),
            Instr::Map {
                targets,
                source,
                mapping,
                output,
            } => write!(
                f,
                "Map({targets:?} <- field {source}, {:p}, output {output})",
                Arc::as_ptr(mapping)
            ),
        }
    }
}

/// Runs a program on a sample: every instruction in order.
#[inline]
pub fn run(program: &[Instr], s: &mut Sample<'_>) {
    for ins in program {
        match ins {
            Instr::Set { fields, value } => s.write(*fields, *value),
            Instr::Function { fields, f } => {
                s.mask = *fields;
                s.role = SampleRole::Field;
                f(s);
                s.mask = Fields::NONE;
            }
            Instr::Dataset {
                fields,
                data,
                filter,
                gradient,
            } => {
                let filter = match gradient {
                    GradientFilter::Cubic { b, c } if s.for_gradient => {
                        Filter::Cubic { b: *b, c: *c }
                    }
                    _ => *filter,
                };
                let v = data.sample(s.p, filter);
                s.write(*fields, v);
            }
            Instr::Spatial { f } => {
                s.role = SampleRole::Spatial;
                f(s);
                s.role = SampleRole::Field;
            }
            Instr::Map {
                targets,
                source,
                mapping,
                output,
            } => {
                let v = mapping.eval(s.fields[*source], *output);
                s.write(*targets, v);
            }
        }
    }
}

/// The shortest prefix of `program` after which `field` cannot change: everything after
/// the last instruction that may write it is irrelevant to that field.
pub fn prefix_for(program: &[Instr], field: Fields) -> usize {
    program
        .iter()
        .rposition(|i| i.writes().intersects(field))
        .map_or(0, |i| i + 1)
}

#[cfg(test)]
mod tests;
