//! Board mounting: a signed axis permutation from the MPU sensor frame to
//! the body frame (FRD: x forward, y right, z down).

/// One body axis: which MPU axis it takes and with which sign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisMap {
    /// Index of the MPU-frame axis (0 = x, 1 = y, 2 = z).
    pub source: u8,
    /// `true` if the body axis is the negated MPU axis.
    pub negate: bool,
}

/// Signed axis permutation `body[i] = ±mpu[axes[i].source]` (MPU frame → body FRD).
///
/// The default assumes the breakout mounted face up with its x arrow
/// forward: body = (x_mpu, −y_mpu, −z_mpu).
///
/// ```
/// use sensor_stack::Mounting;
/// let m = Mounting::default();
/// assert_eq!(m.apply_i32([1, 2, 3]), [1, -2, -3]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mounting {
    axes: [AxisMap; 3],
}

/// Why a mounting description was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MountingError {
    /// An axis index is not 0, 1 or 2.
    AxisOutOfRange,
    /// Two body axes take the same MPU axis (not a permutation).
    RepeatedAxis,
    /// The permutation is a reflection (determinant −1): the body frame would
    /// be left-handed.
    LeftHanded,
}

impl Default for Mounting {
    fn default() -> Self {
        Self::FACE_UP_X_FORWARD
    }
}

impl Mounting {
    /// The breakout face up with its x arrow forward: body = (x_mpu, −y_mpu,
    /// −z_mpu). The default.
    pub const FACE_UP_X_FORWARD: Self = Self {
        axes: [
            AxisMap {
                source: 0,
                negate: false,
            },
            AxisMap {
                source: 1,
                negate: true,
            },
            AxisMap {
                source: 2,
                negate: true,
            },
        ],
    };

    /// Builds a mounting from three axis maps, checking that it is a proper
    /// rotation (a permutation with determinant +1). A `const fn`, so a
    /// board's mounting can be checked when the firmware is compiled:
    ///
    /// ```
    /// use sensor_stack::mounting::{AxisMap, Mounting};
    /// // Face up, x arrow pointing right: forward = y_mpu, right = x_mpu,
    /// // down = −z_mpu.
    /// const M: Mounting = match Mounting::new([
    ///     AxisMap { source: 1, negate: false },
    ///     AxisMap { source: 0, negate: false },
    ///     AxisMap { source: 2, negate: true },
    /// ]) {
    ///     Ok(m) => m,
    ///     Err(_) => panic!("not a rotation"),
    /// };
    /// assert_eq!(M.apply_i32([0, 1, 0]), [1, 0, 0]); // y_mpu is forward
    /// ```
    pub const fn new(axes: [AxisMap; 3]) -> Result<Self, MountingError> {
        let mut seen = [false; 3];
        let mut i = 0;
        while i < 3 {
            let src = axes[i].source as usize;
            if src >= 3 {
                return Err(MountingError::AxisOutOfRange);
            }
            if seen[src] {
                return Err(MountingError::RepeatedAxis);
            }
            seen[src] = true;
            i += 1;
        }
        // Parity of the permutation: even permutations are cyclic shifts.
        let [a0, a1, a2] = axes;
        let even = (a1.source == (a0.source + 1) % 3) && (a2.source == (a1.source + 1) % 3);
        let negations = a0.negate as u8 + a1.negate as u8 + a2.negate as u8;
        let det_positive = even == negations.is_multiple_of(2);
        if !det_positive {
            return Err(MountingError::LeftHanded);
        }
        Ok(Self { axes })
    }

    /// The three axis maps (body x, y, z).
    pub fn axes(&self) -> [AxisMap; 3] {
        self.axes
    }

    /// Applies the permutation to an integer vector in the MPU frame.
    /// Negation saturates (`i32::MIN` becomes `i32::MAX`).
    #[inline]
    pub fn apply_i32(&self, v: [i32; 3]) -> [i32; 3] {
        self.axes.map(|a| {
            let x = match a.source {
                0 => v[0],
                1 => v[1],
                _ => v[2],
            };
            if a.negate {
                x.saturating_neg()
            } else {
                x
            }
        })
    }

    /// Applies the permutation to an `f32` vector in the MPU frame.
    // The same selection as `apply_i32`; kept apart because integer negation
    // must saturate and a generic version would hide that.
    #[inline]
    pub fn apply_f32(&self, v: [f32; 3]) -> [f32; 3] {
        self.axes.map(|a| {
            let x = match a.source {
                0 => v[0],
                1 => v[1],
                _ => v[2],
            };
            if a.negate {
                -x
            } else {
                x
            }
        })
    }

    /// Packs into 9 bits: per body axis, 2 bits of source and 1 sign bit.
    pub fn to_code(&self) -> u16 {
        let mut code = 0u16;
        for (i, a) in self.axes.iter().enumerate() {
            let bits = u16::from(a.source & 3) | (u16::from(a.negate) << 2);
            code |= bits << (3 * i);
        }
        code
    }

    /// Unpacks [`Mounting::to_code`], validating the result.
    pub fn from_code(code: u16) -> Result<Self, MountingError> {
        if code >> 9 != 0 {
            return Err(MountingError::AxisOutOfRange);
        }
        let axis = |i: u16| {
            let bits = (code >> (3 * i)) & 7;
            AxisMap {
                source: (bits & 3) as u8,
                negate: bits & 4 != 0,
            }
        };
        Self::new([axis(0), axis(1), axis(2)])
    }
}

/// Which way the craft lies for one face of the accelerometer's
/// six-position calibration, in the body frame (FRD), as the log tells the
/// builder (README "Calibration on the board"). The defmt form is the
/// instruction in words: "stand it on its tail, nose up", ...
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Face {
    /// The nose (body +x) points up.
    NoseUp,
    /// The nose points down.
    NoseDown,
    /// The right side (body +y) points up: the craft lies on its left side.
    OnLeftSide,
    /// The left side points up: the craft lies on its right side.
    OnRightSide,
    /// Body down (+z) points up.
    UpsideDown,
    /// Level, the right way up.
    Level,
}

#[cfg(feature = "defmt")]
impl defmt::Format for Face {
    // Literal format strings: defmt keeps them on the host, not in flash.
    fn format(&self, f: defmt::Formatter) {
        match self {
            Face::NoseUp => defmt::write!(f, "stand it on its tail, nose up"),
            Face::NoseDown => defmt::write!(f, "stand it on its nose"),
            Face::OnLeftSide => defmt::write!(f, "lay it on its left side"),
            Face::OnRightSide => defmt::write!(f, "lay it on its right side"),
            Face::UpsideDown => defmt::write!(f, "lay it upside down"),
            Face::Level => defmt::write!(f, "lay it flat, the right way up"),
        }
    }
}

/// The face in short words for host tools ("nose up", "left side", ...).
impl core::fmt::Display for Face {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Face::NoseUp => "nose up",
            Face::NoseDown => "nose down",
            Face::OnLeftSide => "left side",
            Face::OnRightSide => "right side",
            Face::UpsideDown => "upside down",
            Face::Level => "level",
        })
    }
}

impl Face {
    /// The order the log asks for the faces in: the right way up first,
    /// then upside down, nose up, nose down, on the left and right sides.
    pub const ORDER: [Face; 6] = [
        Face::Level,
        Face::UpsideDown,
        Face::NoseUp,
        Face::NoseDown,
        Face::OnLeftSide,
        Face::OnRightSide,
    ];
}

impl Mounting {
    /// The face to present next: the first in [`Face::ORDER`] whose
    /// position is not yet captured in `done` (any face is accepted in
    /// any order; this is the one the log names). `None` when all six are.
    // Out of line: called from one log line, not worth inlining there.
    #[inline(never)]
    pub fn next_face(&self, done: calibration::Progress) -> Option<Face> {
        Face::ORDER.into_iter().find(|&f| {
            calibration::Position::ALL
                .into_iter()
                .any(|p| !done.is_done(p) && self.face(p) == f)
        })
    }

    /// How the craft lies when the accelerometer's `position` (a sensor
    /// axis up or down) is presented, through this mounting.
    pub fn face(&self, position: calibration::Position) -> Face {
        let mut up = [0i32; 3];
        if let Some(u) = up.get_mut(usize::from(position.axis())) {
            *u = if position.is_up() { 1 } else { -1 };
        }
        match self.apply_i32(up) {
            [1, _, _] => Face::NoseUp,
            [-1, _, _] => Face::NoseDown,
            [_, 1, _] => Face::OnLeftSide,
            [_, -1, _] => Face::OnRightSide,
            [_, _, 1] => Face::UpsideDown,
            _ => Face::Level,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_face_up_x_forward() {
        let m = Mounting::default();
        // At rest face up the accelerometer reads +1 g on z_mpu; in FRD the
        // specific force at rest points up, i.e. −z_body.
        assert_eq!(m.apply_f32([0.0, 0.0, 1.0]), [0.0, 0.0, -1.0]);
        assert_eq!(Mounting::from_code(m.to_code()), Ok(m));
    }

    #[test]
    fn rejects_reflections_and_repeats() {
        let id = |s, n| AxisMap {
            source: s,
            negate: n,
        };
        assert_eq!(
            Mounting::new([id(0, false), id(1, false), id(2, true)]),
            Err(MountingError::LeftHanded)
        );
        assert_eq!(
            Mounting::new([id(1, false), id(0, false), id(2, false)]),
            Err(MountingError::LeftHanded)
        );
        assert!(Mounting::new([id(1, false), id(0, false), id(2, true)]).is_ok());
        assert!(Mounting::new([id(1, false), id(2, false), id(0, false)]).is_ok());
        assert_eq!(
            Mounting::new([id(0, false), id(0, false), id(2, false)]),
            Err(MountingError::RepeatedAxis)
        );
        assert_eq!(
            Mounting::new([id(3, false), id(0, false), id(2, false)]),
            Err(MountingError::AxisOutOfRange)
        );
    }

    #[test]
    fn every_code_roundtrips_or_is_rejected() {
        let mut proper = 0;
        for code in 0..512u16 {
            if let Ok(m) = Mounting::from_code(code) {
                proper += 1;
                assert_eq!(m.to_code(), code);
            }
        }
        // 24 proper rotations among the 48 signed permutations.
        assert_eq!(proper, 24);
    }

    #[test]
    fn faces_in_words_follow_the_mounting() {
        use calibration::Position;
        let m = Mounting::FACE_UP_X_FORWARD;
        let faces = Position::ALL.map(|p| m.face(p));
        assert_eq!(
            faces,
            [
                Face::NoseUp,      // +x_mpu up: the nose
                Face::NoseDown,    // −x_mpu up
                Face::OnRightSide, // +y_mpu is body −y (left) up
                Face::OnLeftSide,  // −y_mpu up: body +y (right) up
                Face::Level,       // +z_mpu up: face up is right way up
                Face::UpsideDown,  // −z_mpu up
            ]
        );
        // The log's order: level first; each capture moves it on.
        let mut done = calibration::Progress::default();
        for face in Face::ORDER {
            assert_eq!(m.next_face(done), Some(face));
            let p = Position::ALL
                .into_iter()
                .find(|&p| m.face(p) == face)
                .unwrap();
            done.mask |= p.bit();
        }
        assert_eq!(m.next_face(done), None);
        // A face captured out of order is skipped.
        let upside_down = calibration::Progress {
            mask: Position::ZDown.bit(),
        };
        assert_eq!(m.next_face(upside_down), Some(Face::Level));
        // Six positions, six different faces, for every valid mounting.
        for code in 0..512u16 {
            if let Ok(m) = Mounting::from_code(code) {
                let mut f = Position::ALL.map(|p| m.face(p) as u8);
                f.sort_unstable();
                assert_eq!(f, [0, 1, 2, 3, 4, 5], "mounting {code}");
            }
        }
    }
}
