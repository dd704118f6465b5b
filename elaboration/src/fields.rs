//! Message fields by their MAVLink names, read from rust-mavlink's decoded
//! messages through serde (the dialect's own field names and order), so no
//! field layout is written here.

use std::collections::HashMap;
use std::fmt;
use std::hash::{BuildHasherDefault, Hasher};

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::Message;
use serde::ser::{self, Serialize};

use crate::constants;

/// A decoded field value.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    Missing,
    Int(i64),
    Float(f64),
    Str(String),
    /// Arrays, as numbers.
    List(Vec<f64>),
}

/// The field names of a message, in serialization order, with MAVLink's
/// `type` for rust-mavlink's `mavtype`.
pub fn schema(id: u32) -> Option<Vec<String>> {
    let msg = MavMessage::default_message_from_id(id)?;
    let mut names = Names(Vec::new());
    msg.serialize(&mut names).ok()?;
    Some(names.0)
}

/// The name a rule uses for a rust-mavlink field name.
fn mavlink_name(rust: &str) -> &str {
    match rust {
        "mavtype" => "type",
        other => other,
    }
}

/// Decodes `msg`'s fields into `out` (one entry per schema field), reusing
/// its allocations.
pub fn extract(msg: &MavMessage, out: &mut Vec<Field>, names: &mut EnumNames) -> bool {
    let mut sink = Sink {
        names,
        out,
        index: 0,
        depth: 0,
    };
    msg.serialize(&mut sink).is_ok()
}

#[derive(Debug)]
pub struct Unsupported(String);

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for Unsupported {}
impl ser::Error for Unsupported {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Unsupported(msg.to_string())
    }
}

// ------------------------------------------------------------------ names

struct Names(Vec<String>);

macro_rules! unsupported {
    ($($name:ident: $ty:ty),* $(,)?) => {
        $(fn $name(self, _v: $ty) -> Result<(), Unsupported> {
            Err(Unsupported("unexpected value".into()))
        })*
    };
}

impl ser::SerializeStruct for &mut Names {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        _value: &T,
    ) -> Result<(), Unsupported> {
        if key != "type" {
            self.0.push(mavlink_name(key).to_owned());
        }
        Ok(())
    }
    fn end(self) -> Result<(), Unsupported> {
        Ok(())
    }
}

impl<'a> ser::Serializer for &'a mut Names {
    type Ok = ();
    type Error = Unsupported;
    type SerializeSeq = ser::Impossible<(), Unsupported>;
    type SerializeTuple = ser::Impossible<(), Unsupported>;
    type SerializeTupleStruct = ser::Impossible<(), Unsupported>;
    type SerializeTupleVariant = ser::Impossible<(), Unsupported>;
    type SerializeMap = ser::Impossible<(), Unsupported>;
    type SerializeStruct = &'a mut Names;
    type SerializeStructVariant = ser::Impossible<(), Unsupported>;

    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, Unsupported> {
        Ok(self)
    }
    unsupported!(serialize_bool: bool, serialize_i8: i8, serialize_i16: i16, serialize_i32: i32,
        serialize_i64: i64, serialize_u8: u8, serialize_u16: u16, serialize_u32: u32,
        serialize_u64: u64, serialize_f32: f32, serialize_f64: f64, serialize_char: char,
        serialize_str: &str, serialize_bytes: &[u8]);
    fn serialize_none(self) -> Result<(), Unsupported> {
        Err(Unsupported("none".into()))
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), Unsupported> {
        Err(Unsupported("some".into()))
    }
    fn serialize_unit(self) -> Result<(), Unsupported> {
        Err(Unsupported("unit".into()))
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Unsupported> {
        Err(Unsupported("unit struct".into()))
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<(), Unsupported> {
        Err(Unsupported("unit variant".into()))
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: &T,
    ) -> Result<(), Unsupported> {
        Err(Unsupported("newtype".into()))
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), Unsupported> {
        Err(Unsupported("newtype variant".into()))
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, Unsupported> {
        Err(Unsupported("seq".into()))
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, Unsupported> {
        Err(Unsupported("tuple".into()))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, Unsupported> {
        Err(Unsupported("tuple struct".into()))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, Unsupported> {
        Err(Unsupported("tuple variant".into()))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Unsupported> {
        Err(Unsupported("map".into()))
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, Unsupported> {
        Err(Unsupported("struct variant".into()))
    }
}

// ------------------------------------------------------------------ values

/// Enum variant names already looked up, by the address of the dialect's
/// static name (serde hands them out as `&'static str`): numbering an enum
/// field then costs a pointer hash, not a string hash.
#[derive(Debug, Default)]
pub struct EnumNames {
    seen: HashMap<(usize, usize), (String, Option<i64>), AddressHash>,
}

impl EnumNames {
    fn value(&mut self, name: &str) -> Option<i64> {
        let entry = self
            .seen
            .entry((name.as_ptr() as usize, name.len()))
            .or_insert_with(|| (name.to_owned(), constants::value(name)));
        // An address is only a hint: the text decides.
        if entry.0 != name {
            *entry = (name.to_owned(), constants::value(name));
        }
        entry.1
    }
}

type AddressHash = BuildHasherDefault<AddressHasher>;

/// A hasher for addresses (Fibonacci hashing).
#[derive(Debug, Default)]
pub struct AddressHasher(u64);

impl Hasher for AddressHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_usize(&mut self, n: usize) {
        self.write_u64(n as u64);
    }
    fn write_u64(&mut self, n: u64) {
        self.0 = (self.0.rotate_left(5) ^ n).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

struct Sink<'o> {
    names: &'o mut EnumNames,
    out: &'o mut Vec<Field>,
    index: usize,
    depth: usize,
}

impl Sink<'_> {
    fn slot(&mut self) -> &mut Field {
        if self.out.len() <= self.index {
            self.out.resize(self.index + 1, Field::Missing);
        }
        &mut self.out[self.index]
    }

    fn put_int(&mut self, v: i64) {
        *self.slot() = Field::Int(v);
    }

    fn put_float(&mut self, v: f64) {
        *self.slot() = Field::Float(v);
    }

    fn put_str(&mut self, s: &str) {
        // An enum variant name (a tagged struct inside a field) becomes its
        // number when the dialect knows it.
        if self.depth > 1 {
            if let Some(v) = self.names.value(s) {
                return self.put_int(v);
            }
        }
        match self.slot() {
            Field::Str(old) => {
                old.clear();
                old.push_str(s);
            }
            other => *other = Field::Str(s.to_owned()),
        }
    }
}

impl<'a, 'o> ser::Serializer for &'a mut Sink<'o> {
    type Ok = ();
    type Error = Unsupported;
    type SerializeSeq = ListSink<'a, 'o>;
    type SerializeTuple = ListSink<'a, 'o>;
    type SerializeTupleStruct = ser::Impossible<(), Unsupported>;
    type SerializeTupleVariant = ser::Impossible<(), Unsupported>;
    type SerializeMap = ser::Impossible<(), Unsupported>;
    type SerializeStruct = StructSink<'a, 'o>;
    type SerializeStructVariant = ser::Impossible<(), Unsupported>;

    fn is_human_readable(&self) -> bool {
        false
    }
    fn serialize_bool(self, v: bool) -> Result<(), Unsupported> {
        self.put_int(v as i64);
        Ok(())
    }
    fn serialize_i8(self, v: i8) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_i16(self, v: i16) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_i32(self, v: i32) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_i64(self, v: i64) -> Result<(), Unsupported> {
        self.put_int(v);
        Ok(())
    }
    fn serialize_u8(self, v: u8) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_u16(self, v: u16) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_u32(self, v: u32) -> Result<(), Unsupported> {
        self.put_int(v.into());
        Ok(())
    }
    fn serialize_u64(self, v: u64) -> Result<(), Unsupported> {
        match i64::try_from(v) {
            Ok(i) => self.put_int(i),
            Err(_) => self.put_float(v as f64),
        }
        Ok(())
    }
    fn serialize_f32(self, v: f32) -> Result<(), Unsupported> {
        self.put_float(v.into());
        Ok(())
    }
    fn serialize_f64(self, v: f64) -> Result<(), Unsupported> {
        self.put_float(v);
        Ok(())
    }
    fn serialize_char(self, v: char) -> Result<(), Unsupported> {
        self.put_int(v as i64);
        Ok(())
    }
    fn serialize_str(self, v: &str) -> Result<(), Unsupported> {
        self.put_str(v);
        Ok(())
    }
    fn serialize_bytes(self, v: &[u8]) -> Result<(), Unsupported> {
        let list: Vec<f64> = v.iter().map(|&b| b as f64).collect();
        *self.slot() = Field::List(list);
        Ok(())
    }
    fn serialize_none(self) -> Result<(), Unsupported> {
        *self.slot() = Field::Missing;
        Ok(())
    }
    fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<(), Unsupported> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), Unsupported> {
        *self.slot() = Field::Missing;
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Unsupported> {
        self.serialize_unit()
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        name: &'static str,
    ) -> Result<(), Unsupported> {
        self.put_str(name);
        Ok(())
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), Unsupported> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        v: &T,
    ) -> Result<(), Unsupported> {
        v.serialize(self)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<ListSink<'a, 'o>, Unsupported> {
        Ok(ListSink::new(self))
    }
    fn serialize_tuple(self, _: usize) -> Result<ListSink<'a, 'o>, Unsupported> {
        Ok(ListSink::new(self))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, Unsupported> {
        Err(Unsupported("tuple struct".into()))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, Unsupported> {
        Err(Unsupported("tuple variant".into()))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Unsupported> {
        Err(Unsupported("map".into()))
    }
    fn serialize_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<StructSink<'a, 'o>, Unsupported> {
        self.depth += 1;
        Ok(StructSink { sink: self })
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, Unsupported> {
        Err(Unsupported("struct variant".into()))
    }
}

pub struct StructSink<'a, 'o> {
    sink: &'a mut Sink<'o>,
}

impl ser::SerializeStruct for StructSink<'_, '_> {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), Unsupported> {
        if self.sink.depth == 1 {
            // The message itself: skip its tag, one slot per field.
            if key == "type" {
                return Ok(());
            }
            v.serialize(&mut *self.sink)?;
            self.sink.index += 1;
            Ok(())
        } else {
            // An enum inside a field: `{"type": "VARIANT_NAME"}`.
            v.serialize(&mut *self.sink)
        }
    }
    fn end(self) -> Result<(), Unsupported> {
        self.sink.depth -= 1;
        Ok(())
    }
}

pub struct ListSink<'a, 'o> {
    sink: &'a mut Sink<'o>,
    list: Vec<f64>,
    /// One element's value, reused for every element.
    scratch: Vec<Field>,
}

impl<'a, 'o> ListSink<'a, 'o> {
    fn new(sink: &'a mut Sink<'o>) -> Self {
        let list = match sink.slot() {
            Field::List(l) => {
                let mut l = std::mem::take(l);
                l.clear();
                l
            }
            _ => Vec::new(),
        };
        ListSink {
            sink,
            list,
            scratch: Vec::with_capacity(1),
        }
    }

    fn push<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Unsupported> {
        let mut element = Sink {
            names: &mut *self.sink.names,
            out: &mut self.scratch,
            index: 0,
            depth: 2,
        };
        v.serialize(&mut element)?;
        self.list.push(match self.scratch.first() {
            Some(Field::Int(i)) => *i as f64,
            Some(Field::Float(f)) => *f,
            _ => f64::NAN,
        });
        Ok(())
    }

    fn finish(self) {
        *self.sink.slot() = Field::List(self.list);
    }
}

impl ser::SerializeSeq for ListSink<'_, '_> {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Unsupported> {
        self.push(v)
    }
    fn end(self) -> Result<(), Unsupported> {
        self.finish();
        Ok(())
    }
}

impl ser::SerializeTuple for ListSink<'_, '_> {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), Unsupported> {
        self.push(v)
    }
    fn end(self) -> Result<(), Unsupported> {
        self.finish();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::*;
    use mavlink::MessageData;

    #[test]
    fn heartbeat_fields_by_mavlink_name() {
        let names = schema(0).expect("HEARTBEAT is known");
        assert_eq!(
            names,
            [
                "custom_mode",
                "type",
                "autopilot",
                "base_mode",
                "system_status",
                "mavlink_version"
            ]
        );
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_CRITICAL,
            mavlink_version: 3,
        });
        let mut out = Vec::new();
        assert!(extract(&msg, &mut out, &mut EnumNames::default()));
        assert_eq!(
            out,
            vec![
                Field::Int(4),
                Field::Int(2),
                Field::Int(3),
                Field::Int(129),
                Field::Int(5),
                Field::Int(3)
            ]
        );
    }

    #[test]
    fn text_and_arrays() {
        let id = STATUSTEXT_DATA::ID;
        let names = schema(id).expect("STATUSTEXT");
        let text = names.iter().position(|n| n == "text").expect("text field");
        let mut data = STATUSTEXT_DATA::DEFAULT;
        data.text = mavlink::types::CharArray::new(
            *b"Potential Thrust Loss (3)\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0",
        );
        let mut out = Vec::new();
        assert!(extract(
            &MavMessage::STATUSTEXT(data),
            &mut out,
            &mut EnumNames::default()
        ));
        assert_eq!(out[text], Field::Str("Potential Thrust Loss (3)".into()));

        let names = schema(ESC_TELEMETRY_1_TO_4_DATA::ID).expect("ESC telemetry");
        let rpm = names.iter().position(|n| n == "rpm").expect("rpm");
        let mut esc = ESC_TELEMETRY_1_TO_4_DATA::DEFAULT;
        esc.rpm = [1000, 0, 1200, 1300];
        assert!(extract(
            &MavMessage::ESC_TELEMETRY_1_TO_4(esc),
            &mut out,
            &mut EnumNames::default()
        ));
        assert_eq!(out[rpm], Field::List(vec![1000.0, 0.0, 1200.0, 1300.0]));
    }
}
