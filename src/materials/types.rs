//! MaterialX data types (specification 1.39, "MaterialX Data Types") and
//! constant values. Every numeric value is held as up to four f32 channels;
//! `integer` inputs are constants (see `graph.rs`) and are held as an f32.

use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Type {
    Float,
    Color3,
    Color4,
    Vector2,
    Vector3,
    Vector4,
    Integer,
    Boolean,
    String,
    Filename,
}

impl Type {
    /// The MaterialX type name (`type="..."` in a document).
    pub fn name(self) -> &'static str {
        match self {
            Type::Float => "float",
            Type::Color3 => "color3",
            Type::Color4 => "color4",
            Type::Vector2 => "vector2",
            Type::Vector3 => "vector3",
            Type::Vector4 => "vector4",
            Type::Integer => "integer",
            Type::Boolean => "boolean",
            Type::String => "string",
            Type::Filename => "filename",
        }
    }

    pub fn from_name(s: &str) -> Option<Type> {
        Some(match s {
            "float" => Type::Float,
            "color3" => Type::Color3,
            "color4" => Type::Color4,
            "vector2" => Type::Vector2,
            "vector3" => Type::Vector3,
            "vector4" => Type::Vector4,
            "integer" => Type::Integer,
            "boolean" => Type::Boolean,
            "string" => Type::String,
            "filename" => Type::Filename,
            _ => return None,
        })
    }

    /// Number of f32 channels (0 for strings).
    pub fn width(self) -> usize {
        match self {
            Type::Float | Type::Integer | Type::Boolean => 1,
            Type::Vector2 => 2,
            Type::Color3 | Type::Vector3 => 3,
            Type::Color4 | Type::Vector4 => 4,
            Type::String | Type::Filename => 0,
        }
    }

    /// A float-channel type a graph can compute at run time (the rest are constants).
    pub fn is_varying(self) -> bool {
        matches!(
            self,
            Type::Float
                | Type::Color3
                | Type::Color4
                | Type::Vector2
                | Type::Vector3
                | Type::Vector4
        )
    }

    /// The GLSL type of a varying value.
    pub fn glsl(self) -> &'static str {
        match self.width() {
            1 if self == Type::Integer => "int",
            1 => "float",
            2 => "vec2",
            3 => "vec3",
            _ => "vec4",
        }
    }
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A constant numeric value: `ty.width()` channels of `v` are used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Value {
    pub ty: Type,
    pub v: [f32; 4],
}

impl Value {
    pub fn new(ty: Type, c: &[f32]) -> Value {
        let mut v = [0.0; 4];
        v[..c.len()].copy_from_slice(c);
        Value { ty, v }
    }

    pub fn float(x: f32) -> Value {
        Value::new(Type::Float, &[x])
    }

    /// The used channels.
    pub fn channels(&self) -> &[f32] {
        &self.v[..self.ty.width()]
    }

    /// Parses a MaterialX value string ("0.5", "1, 0.5, 0"; booleans "true"/"false").
    pub fn parse(ty: Type, s: &str) -> Result<Value, String> {
        let n = ty.width();
        if ty == Type::Boolean {
            return match s.trim() {
                "true" => Ok(Value::new(ty, &[1.0])),
                "false" => Ok(Value::new(ty, &[0.0])),
                o => Err(format!("`{o}` is not a boolean")),
            };
        }
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if parts.len() != n {
            return Err(format!(
                "`{s}` has {} component(s), {ty} needs {n}",
                parts.len()
            ));
        }
        let mut v = [0.0f32; 4];
        for (i, p) in parts.iter().enumerate() {
            v[i] = if ty == Type::Integer {
                p.parse::<i32>().map_err(|_| {
                    // An integer too large for 32 bits is one, out of range.
                    if p.parse::<i128>().is_ok() {
                        format!("`{p}` is out of the 32-bit integer range")
                    } else {
                        format!("`{p}` is not an integer")
                    }
                })? as f32
            } else {
                p.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("`{p}` is not a finite number"))?
            };
        }
        Ok(Value { ty, v })
    }

    /// The value as a GLSL literal of its type.
    pub fn glsl(&self) -> String {
        let f = |x: f32| -> String {
            if x.is_finite() {
                // Bit-exact: the shortest representation that round-trips.
                let s = format!("{x:?}");
                if s.contains('.') || s.contains('e') {
                    s
                } else {
                    format!("{s}.0")
                }
            } else {
                // Folding can make a constant infinite or NaN (divide(1, 0),
                // exp(100)); the CPU evaluator keeps it, so the GPU gets the
                // same bits (until session 53: 0.0, which made e.g. an
                // overflowing emission black on the GPU and +inf on the CPU).
                format!("uintBitsToFloat({:#010x}u)", x.to_bits())
            }
        };
        match self.ty {
            Type::Integer => format!("{}", self.v[0] as i32),
            _ if self.ty.width() == 1 => f(self.v[0]),
            _ => format!(
                "{}({})",
                self.ty.glsl(),
                self.channels()
                    .iter()
                    .map(|x| f(*x))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}
