//! The list of the commands of `vlib.h` (and, apart, of its extensions): each command once, with
//! the module of its API area, in the order the header declares them (the order of the API,
//! `docs/commands.md`). The number of commands, the re-exports in `lib.rs` and the lists the tests
//! check against all come from it. This module owns the list only: the commands are defined in
//! their area modules, the header order follows from the order of those modules and of the
//! functions in them, and the scopes each command is legal in are the core's (`vlib_core::scope`).
//!
//! The integration tests compile this file too (they cannot link the library as Rust), so it refers
//! to nothing else in the crate. `capi/tests/symbols.rs` checks the list against the functions
//! `include/vlib.h` declares, in order, and against the core's `Command::ALL`.

/// Calls `$then!` with every command as `module::name`, in header order. (`lib.rs` declares this
/// module with `#[macro_use]`, so the macro is visible after that line.)
macro_rules! for_each_command {
    ($then:ident) => {
        $then! {
            session::vlInit,
            session::vlEnd,
            session::vlError,
            session::vlErrorString,
            scene::vlScene,
            scene::vlImage,
            scene::vlVolume,
            scene::vlCamera,
            scene::vlBackground,
            scene::vlSuperSample,
            scene::vlAmbient,
            scene::vlPointLight,
            scene::vlDirectionalLight,
            scene::vlRenderType,
            scene::vlStepSize,
            scene::vlSurface,
            scene::vlToggle,
            scene::vlRecursion,
            scene::vlInterpolationType,
            scene::vlCubicFilter,
            scene::vlNeighborhood,
            data::vlLoad,
            data::vlUnload,
            data::vlSample,
            data::vlMapping,
            object::vlObject,
            object::vlScale,
            object::vlTranslate,
            object::vlRotate,
            object::vlFlip,
            object::vlMatrix,
            object::vlBoundary,
            object::vlSpatial,
            object::vlSet,
            object::vlFunction,
            object::vlDataset,
            object::vlMap,
            object::vlNormal,
            sampling::vlField,
            sampling::vlPosition,
            sampling::vlChildCount,
            sampling::vlChildHit,
            sampling::vlChildField,
            sampling::vlChildNormal,
        }
    };
}

/// The names in a `for_each_command!` list, as an array.
macro_rules! names {
    ($($module:ident::$name:ident),+ $(,)?) => {
        [$(stringify!($name)),+]
    };
}

/// The C names of the commands, in header order.
pub const COMMANDS: &[&str] = &for_each_command!(names);

/// The number of commands.
pub const COMMAND_COUNT: usize = COMMANDS.len();

/// The C names of the extensions (`extensions`: functions beyond the commands, declared after
/// them in `vlib.h`), in header order.
pub const EXTENSIONS: [&str; 5] = [
    "vlProgress",
    "vlCancel",
    "vlRenderBuffer",
    "vlGradientFilter",
    "vlVersion",
];
