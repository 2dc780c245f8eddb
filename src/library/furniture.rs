//! Furniture classes: `furniture/<class>/<class>.toml` and the OBJ meshes beside it.
//!
//! STUB: the furniture work replaces this with the full schema (dimension ranges, rooms,
//! placement rules, variants read with tobj).

use super::{LibraryError, LibraryFile};
use crate::scene::ObjectClass;

/// One furniture class and its variants.
#[derive(Clone, Debug, PartialEq)]
pub struct FurnitureClass {
    pub class: ObjectClass,
}

/// Parses the furniture library.
pub fn parse_furniture(_files: &[LibraryFile]) -> Result<Vec<FurnitureClass>, LibraryError> {
    Ok(Vec::new())
}
