//! The object-scope commands of the state machine: opening an object (`vlObject`), its
//! transforms (`vlScale`, `vlTranslate`, `vlRotate`, `vlFlip`, `vlMatrix`, `vlBoundary`) and its
//! field program (`vlSpatial`, `vlSet`, `vlFunction`, `vlDataset`, `vlMap`, `vlNormal`). Like
//! every command they check their scope, validate everything, and only then change the open
//! object. Closing an object is `vlEnd`'s, in `library`.

use super::library::{finite, invertible, positive, Library};
use crate::api::library::MAX_DEPTH;
use crate::api::scope::Command;
use crate::error::{err, Error, ErrorCode, Result};
use crate::model::program::{clamp_field, Instr, NormalFn, Sample};
use crate::model::scene::ObjectDesc;
use crate::types::{axes, DatasetId, Fields, MappingId};
use glam::{DMat4, DVec4};
use std::sync::Arc;

impl Library {
    /// `vlObject`: opens an object capturing the rendering state in force. Inside an object it
    /// opens a child, placed in its parent's space; only root objects are rendered.
    pub fn object(&mut self) -> Result<()> {
        self.check(Command::Object)?;
        if self.scene_mut().open.len() >= MAX_DEPTH {
            return err(
                ErrorCode::BadValue,
                format!("vlObject: objects nest at most {MAX_DEPTH} deep"),
            );
        }
        let s = self.scene_mut();
        let state = s.settings.render.clone();
        s.open.push(ObjectDesc::new(state));
        Ok(())
    }

    fn transform(&mut self, cmd: Command, m: DMat4) -> Result<()> {
        self.check(cmd)?;
        let obj = self.object_mut();
        let next = m * obj.to_world;
        invertible(cmd.name(), &next)?;
        obj.to_world = next;
        Ok(())
    }

    /// `vlScale`: non-zero finite factors (negative mirrors).
    pub fn scale(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Scale)?;
        finite("vlScale", &[x, y, z])?;
        if [x, y, z].contains(&0.0) {
            return err(
                ErrorCode::BadValue,
                "vlScale: a factor of 0 makes the object flat",
            );
        }
        self.transform(
            Command::Scale,
            DMat4::from_scale(crate::model::scene::v3([x, y, z])),
        )
    }

    /// `vlTranslate`.
    pub fn translate(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Translate)?;
        finite("vlTranslate", &[x, y, z])?;
        self.transform(
            Command::Translate,
            DMat4::from_translation(crate::model::scene::v3([x, y, z])),
        )
    }

    /// `vlRotate`: degrees about x, then y, then z.
    pub fn rotate(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Rotate)?;
        finite("vlRotate", &[x, y, z])?;
        let r = |d: f32| (d as f64).to_radians();
        let m = DMat4::from_rotation_z(r(z))
            * DMat4::from_rotation_y(r(y))
            * DMat4::from_rotation_x(r(x));
        self.transform(Command::Rotate, m)
    }

    /// `vlFlip`: mirrors object space (p → 1 − p) on the axes of the mask (`VL_X|VL_Y|VL_Z`).
    /// Flips act in object space, before every other transform, whenever they are issued.
    pub fn flip(&mut self, axes_mask: i32) -> Result<()> {
        self.check(Command::Flip)?;
        if axes_mask & !(axes::X | axes::Y | axes::Z) != 0 {
            return err(
                ErrorCode::BadEnum,
                format!("vlFlip: axis mask {axes_mask:#x} has unknown bits"),
            );
        }
        let obj = self.object_mut();
        for (i, bit) in [axes::X, axes::Y, axes::Z].iter().enumerate() {
            if axes_mask & bit != 0 {
                obj.flip[i] = !obj.flip[i];
            }
        }
        Ok(())
    }

    /// `vlMatrix`: a general affine 4×4 transform, row-major, acting on column vectors
    /// (translation in the last column); the bottom row must be (0, 0, 0, 1).
    pub fn matrix(&mut self, m: &[f32; 16]) -> Result<()> {
        self.check(Command::Matrix)?;
        finite("vlMatrix", m)?;
        if m[12..16] != [0.0, 0.0, 0.0, 1.0] {
            return err(
                ErrorCode::BadValue,
                "vlMatrix: only affine transforms (bottom row 0 0 0 1) are supported",
            );
        }
        let row = |i: usize| {
            DVec4::new(
                m[4 * i] as f64,
                m[4 * i + 1] as f64,
                m[4 * i + 2] as f64,
                m[4 * i + 3] as f64,
            )
        };
        let mat = DMat4::from_cols(row(0), row(1), row(2), row(3)).transpose();
        self.transform(Command::Matrix, mat)
    }

    /// Places the object where dataset `id`'s nodes lie in physical space (its
    /// [`crate::Geometry`], from the sidecar `vlconvert` writes): the transform taking the unit
    /// cube's corner (0, 0, 0) to node (0, 0, 0) and (1, 1, 1) to the last node, in
    /// millimetres in RAS (+x right, +y anterior, +z superior), so a dataset assigned to the
    /// object shows at its physical size and anatomical orientation. Composed after the
    /// object's earlier transforms, like `vlMatrix` (whose scope it has). An axis of one node
    /// gets one node's spacing. `BadId` for an unknown id, `BadValue` for a dataset without
    /// geometry. Not a command of the C API (vlaux's `vluPlace` calls it).
    pub fn place_dataset(&mut self, id: DatasetId) -> Result<()> {
        self.check(Command::Matrix)?;
        let d = self.datasets.get(&id).cloned().ok_or_else(|| {
            crate::error::Error::new(ErrorCode::BadId, format!("place_dataset: no dataset {id}"))
        })?;
        let g = d.geometry().ok_or_else(|| {
            crate::error::Error::new(
                ErrorCode::BadValue,
                format!(
                    "place_dataset: dataset {id} has no geometry (no sidecar beside its file: \
                     convert it with vlconvert from a format that has one)"
                ),
            )
        })?;
        let dims = d.dims();
        let a = g.affine();
        // Column c of A, scaled by the node count along axis c less one (at least one).
        let col = |c: usize| {
            let n = dims[c].saturating_sub(1).max(1) as f64;
            glam::DVec4::new(a[0][c] * n, a[1][c] * n, a[2][c] * n, 0.0)
        };
        let t = glam::DVec4::new(a[0][3], a[1][3], a[2][3], 1.0);
        self.transform(Command::Matrix, DMat4::from_cols(col(0), col(1), col(2), t))
    }

    /// `vlBoundary`: scales the boundary box about the cube centre (positive factors).
    pub fn boundary(&mut self, x: f32, y: f32, z: f32) -> Result<()> {
        self.check(Command::Boundary)?;
        positive("vlBoundary", &[x, y, z])?;
        self.object_mut().boundary = [x, y, z];
        Ok(())
    }

    /// `vlSpatial`: an instruction running a spatial transfer function, which may move the
    /// sample point ([`Sample::set_position`]); later instructions see the new point.
    pub fn spatial<F>(&mut self, f: F) -> Result<()>
    where
        F: Fn(&mut Sample) + Send + Sync + 'static,
    {
        self.spatial_arc(Arc::new(f))
    }

    /// `vlSpatial` with a shared function.
    pub fn spatial_arc(&mut self, f: crate::model::program::FieldFn) -> Result<()> {
        self.check(Command::Spatial)?;
        self.object_mut().program.push(Instr::Spatial { f });
        Ok(())
    }

    /// `vlSet` in an object: an instruction assigning a constant (clamped to [0, 1], NaN → 0).
    pub fn set(&mut self, fields: Fields, value: f32) -> Result<()> {
        self.check(Command::Set)?;
        fields.validate()?;
        self.object_mut().program.push(Instr::Set {
            fields,
            value: clamp_field(value),
        });
        Ok(())
    }

    /// `vlFunction`: an instruction running `f` at each sample; it may write `fields`.
    pub fn function<F>(&mut self, fields: Fields, f: F) -> Result<()>
    where
        F: Fn(&mut Sample) + Send + Sync + 'static,
    {
        self.function_arc(fields, Arc::new(f))
    }

    /// `vlFunction` with a shared function.
    pub fn function_arc(
        &mut self,
        fields: Fields,
        f: crate::model::program::FieldFn,
    ) -> Result<()> {
        self.check(Command::Function)?;
        fields.validate()?;
        self.object_mut()
            .program
            .push(Instr::Function { fields, f });
        Ok(())
    }

    /// `vlDataset`: an instruction writing dataset `id`, interpolated with the filter in force
    /// now, to `fields`.
    pub fn dataset(&mut self, fields: Fields, id: DatasetId) -> Result<()> {
        self.check(Command::Dataset)?;
        fields.validate()?;
        let data =
            self.datasets.get(&id).cloned().ok_or_else(|| {
                Error::new(ErrorCode::BadId, format!("vlDataset: no dataset {id}"))
            })?;
        let filter = self.filter();
        let gradient = self.settings().render.gradient;
        self.object_mut().program.push(Instr::Dataset {
            fields,
            data,
            filter,
            gradient,
        });
        Ok(())
    }

    /// `vlMap`: targets = Φ(mapping)(source), with `output` counted from 1.
    pub fn map(
        &mut self,
        targets: Fields,
        source: Fields,
        mapping: MappingId,
        output: i32,
    ) -> Result<()> {
        self.check(Command::Map)?;
        targets.validate()?;
        let source = source.validate_single()?;
        let m =
            self.mappings.get(&mapping).cloned().ok_or_else(|| {
                Error::new(ErrorCode::BadId, format!("vlMap: no mapping {mapping}"))
            })?;
        if output < 1 || output as usize > m.outputs() {
            return err(
                ErrorCode::BadIndex,
                format!(
                    "vlMap: output {output} of mapping {mapping}, which has {} output(s)",
                    m.outputs()
                ),
            );
        }
        self.object_mut().program.push(Instr::Map {
            targets,
            source,
            mapping: m,
            output: output as usize - 1,
        });
        Ok(())
    }

    /// `vlNormal`: appends a normal function to the object's chain.
    pub fn normal<F>(&mut self, f: F) -> Result<()>
    where
        F: Fn(&mut [f32; 3], &mut Sample) + Send + Sync + 'static,
    {
        self.normal_arc(Arc::new(f))
    }

    /// `vlNormal` with a shared function.
    pub fn normal_arc(&mut self, f: NormalFn) -> Result<()> {
        self.check(Command::Normal)?;
        self.object_mut().normals.push(f);
        Ok(())
    }
}
