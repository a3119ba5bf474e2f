//! The scopes of the state machine and the one table of which command is legal where.
//!
//! `vlInit … vlEnd` (library) ⊃ `vlScene … vlEnd` (scene) ⊃ `vlObject … vlEnd` (object, nestable);
//! field and normal functions run in a fourth scope, the sample scope. Before `vlInit` (and after
//! the final `vlEnd`) the library is uninitialised. Every command checks [`legal`] first; an
//! illegal call changes nothing and reports [`ErrorCode::BadScope`](crate::ErrorCode::BadScope).
//!
//! It owns the scopes and the table; the validation of arguments and the state each command
//! changes are the `Library`'s.

/// Where the caller is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scope {
    /// Before `vlInit` or after the final `vlEnd`.
    Uninitialised,
    /// Between `vlInit` and `vlEnd`, outside any scene.
    Library,
    /// Inside a scene, outside any object.
    Scene,
    /// Inside an object specification.
    Object,
    /// Inside a field, spatial or normal function during rendering.
    Sample,
}

impl Scope {
    /// All scopes.
    pub const ALL: [Scope; 5] = [
        Scope::Uninitialised,
        Scope::Library,
        Scope::Scene,
        Scope::Object,
        Scope::Sample,
    ];

    fn bit(self) -> u8 {
        1 << self as u8
    }
}

const U: u8 = 1 << Scope::Uninitialised as u8;
const L: u8 = 1 << Scope::Library as u8;
const S: u8 = 1 << Scope::Scene as u8;
const O: u8 = 1 << Scope::Object as u8;
const X: u8 = 1 << Scope::Sample as u8;

macro_rules! commands {
    ($($(#[$doc:meta])* $variant:ident = $name:literal, $scopes:expr;)+) => {
        /// The 44 commands of the API, in the order of `api.md`.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Command {
            $($(#[$doc])* $variant),+
        }

        impl Command {
            /// All 44 commands, in order.
            pub const ALL: &'static [Command] = &[$(Command::$variant),+];

            /// The C name of the command.
            pub fn name(self) -> &'static str {
                match self {
                    $(Command::$variant => $name),+
                }
            }

            fn scopes(self) -> u8 {
                match self {
                    $(Command::$variant => $scopes),+
                }
            }
        }
    };
}

commands! {
    /// `vlInit`
    Init = "vlInit", U;
    /// `vlEnd`
    End = "vlEnd", L | S | O;
    /// `vlError`
    Error = "vlError", U | L | S | O | X;
    /// `vlErrorString`
    ErrorString = "vlErrorString", U | L | S | O | X;
    /// `vlScene`
    Scene = "vlScene", L;
    /// `vlImage`
    Image = "vlImage", S;
    /// `vlVolume`
    Volume = "vlVolume", S;
    /// `vlCamera`
    Camera = "vlCamera", L | S;
    /// `vlBackground`
    Background = "vlBackground", L | S;
    /// `vlSuperSample`
    SuperSample = "vlSuperSample", L | S;
    /// `vlAmbient`
    Ambient = "vlAmbient", L | S;
    /// `vlPointLight`
    PointLight = "vlPointLight", S;
    /// `vlDirectionalLight`
    DirectionalLight = "vlDirectionalLight", S;
    /// `vlRenderType`
    RenderType = "vlRenderType", L | S;
    /// `vlStepSize`
    StepSize = "vlStepSize", L | S;
    /// `vlSurface`
    Surface = "vlSurface", L | S;
    /// `vlToggle`
    Toggle = "vlToggle", L | S;
    /// `vlRecursion`
    Recursion = "vlRecursion", L | S;
    /// `vlInterpolationType`
    InterpolationType = "vlInterpolationType", L | S;
    /// `vlCubicFilter`
    CubicFilter = "vlCubicFilter", L | S;
    /// `vlNeighborhood`
    Neighborhood = "vlNeighborhood", L | S;
    /// `vlLoad`
    Load = "vlLoad", L | S;
    /// `vlUnload`
    Unload = "vlUnload", L | S;
    /// `vlSample`
    Sample = "vlSample", L | S | O | X;
    /// `vlMapping`
    Mapping = "vlMapping", L | S;
    /// `vlObject`
    Object = "vlObject", S | O;
    /// `vlScale`
    Scale = "vlScale", O;
    /// `vlTranslate`
    Translate = "vlTranslate", O;
    /// `vlRotate`
    Rotate = "vlRotate", O;
    /// `vlFlip`
    Flip = "vlFlip", O;
    /// `vlMatrix`
    Matrix = "vlMatrix", O;
    /// `vlBoundary`
    Boundary = "vlBoundary", O;
    /// `vlSpatial`
    Spatial = "vlSpatial", O;
    /// `vlSet`
    Set = "vlSet", O | X;
    /// `vlFunction`
    Function = "vlFunction", O;
    /// `vlDataset`
    Dataset = "vlDataset", O;
    /// `vlMap`
    Map = "vlMap", O;
    /// `vlNormal`
    Normal = "vlNormal", O;
    /// `vlField`
    Field = "vlField", X;
    /// `vlPosition`
    Position = "vlPosition", X;
    /// `vlChildCount`
    ChildCount = "vlChildCount", X;
    /// `vlChildHit`
    ChildHit = "vlChildHit", X;
    /// `vlChildField`
    ChildField = "vlChildField", X;
    /// `vlChildNormal`
    ChildNormal = "vlChildNormal", X;
}

/// Whether `command` may be called in `scope`.
pub fn legal(command: Command, scope: Scope) -> bool {
    command.scopes() & scope.bit() != 0
}

/// The legality check as a `Result`, naming the command and the scope in the message.
pub fn require(command: Command, scope: Scope) -> crate::Result<()> {
    if legal(command, scope) {
        Ok(())
    } else {
        crate::error::err(
            crate::ErrorCode::BadScope,
            format!("{} is not legal in {:?} scope", command.name(), scope),
        )
    }
}

#[cfg(test)]
mod tests;
