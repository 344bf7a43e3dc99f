//! Where a setting lives in [`PipelineSettings`]: a typed mutable reference ([`Slot`]), found
//! by the setting's id through one `match` generated from the table (`table.rs`). One small
//! accessor for every setting instead of a pair of functions per setting.

use ekf_core::axis_map::AxisMap;
use ekf_core::Vec3;

use super::Value;
use crate::settings::PipelineSettings;

/// A typed reference to one setting's storage (internal units).
pub(super) enum Slot<'a> {
    F32(&'a mut f32),
    Vec3(&'a mut Vec3),
    Arr3(&'a mut [f32; 3]),
    Bool(&'a mut bool),
    U16(&'a mut u16),
    U8(&'a mut u8),
    Axes(&'a mut AxisMap),
}

macro_rules! slot_from {
    ($($t:ty => $v:ident),*) => {
        $(impl<'a> From<&'a mut $t> for Slot<'a> {
            fn from(r: &'a mut $t) -> Self {
                Slot::$v(r)
            }
        })*
    };
}
slot_from!(f32 => F32, Vec3 => Vec3, [f32; 3] => Arr3, bool => Bool, u16 => U16, u8 => U8,
    AxisMap => Axes);

impl Slot<'_> {
    /// The stored value.
    pub(super) fn read(&self) -> Value {
        match self {
            Slot::F32(x) => Value::F32(**x),
            Slot::Vec3(v) => Value::Vec3(v.to_array()),
            Slot::Arr3(a) => Value::Vec3(**a),
            Slot::Bool(b) => Value::Bool(**b),
            Slot::U16(n) => Value::U16(**n),
            Slot::U8(n) => Value::U16(u16::from(**n)),
            Slot::Axes(m) => Value::Axes(**m),
        }
    }

    /// Store `v`; a value of another kind (or a `u16` too large for a `u8` field) is ignored.
    pub(super) fn write(self, v: Value) {
        match (self, v) {
            (Slot::F32(x), Value::F32(y)) => *x = y,
            (Slot::Vec3(x), Value::Vec3(y)) => *x = Vec3::from_array(y),
            (Slot::Arr3(x), Value::Vec3(y)) => *x = y,
            (Slot::Bool(x), Value::Bool(y)) => *x = y,
            (Slot::U16(x), Value::U16(y)) => *x = y,
            (Slot::U8(x), Value::U16(y)) => {
                if let Ok(y) = u8::try_from(y) {
                    *x = y;
                }
            }
            (Slot::Axes(x), Value::Axes(y)) => *x = y,
            _ => {}
        }
    }
}

/// The slot of the setting with flash id `id` (`None` for an unknown id).
pub(super) fn slot(s: &mut PipelineSettings, id: u16) -> Option<Slot<'_>> {
    super::table::slot(s, id)
}
