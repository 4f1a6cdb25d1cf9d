//! Reads an ONNX model file's graph without ONNX Runtime — its nodes, their attributes and the
//! weights — so our own WGSL passes can run a network on the splatting device
//! (`refine::wgsl`). A reader of the protobuf wire format for just the fields that needs;
//! everything else in the file is skipped.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
#[error("{path}: {problem}")]
pub struct ModelError {
    pub path: PathBuf,
    pub problem: String,
}

/// A tensor stored in the file (an initializer or a `Constant` node's value).
#[derive(Clone, Debug, PartialEq)]
pub struct Tensor {
    pub dims: Vec<i64>,
    pub data: TensorData,
}

#[derive(Clone, Debug, PartialEq)]
pub enum TensorData {
    F32(Vec<f32>),
    I64(Vec<i64>),
}

#[derive(Clone, Debug, PartialEq)]
pub enum Attribute {
    Float(f32),
    Int(i64),
    Ints(Vec<i64>),
    Floats(Vec<f32>),
    String(String),
    Tensor(Tensor),
}

#[derive(Clone, Debug, Default)]
pub struct Node {
    pub op: String,
    /// Value names; an empty name is an omitted optional input.
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    pub attributes: HashMap<String, Attribute>,
}

/// A graph input's or output's name and dims (`None`: a named, free dimension).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ValueInfo {
    pub name: String,
    pub dims: Vec<Option<i64>>,
}

/// The model's main graph, nodes in the file's (topological) order, and its metadata.
#[derive(Debug, Default)]
pub struct Model {
    pub nodes: Vec<Node>,
    pub initializers: HashMap<String, Tensor>,
    /// The graph's inputs that are not initializers, and its outputs.
    pub inputs: Vec<ValueInfo>,
    pub outputs: Vec<ValueInfo>,
    pub metadata: HashMap<String, String>,
}

impl Model {
    /// Reads the model file at `path`.
    pub fn read(path: &Path) -> Result<Self, ModelError> {
        let fail = |problem: String| ModelError {
            path: path.to_path_buf(),
            problem,
        };
        let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        Self::parse(&bytes).map_err(|e| fail(format!("not a readable ONNX model: {e}")))
    }

    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        let mut model = Model::default();
        let mut graph = false;
        for field in Fields(bytes) {
            match field? {
                (7, Value::Bytes(b)) => {
                    parse_graph(b, &mut model)?;
                    graph = true;
                }
                (14, Value::Bytes(b)) => {
                    let (mut key, mut value) = (String::new(), String::new());
                    for field in Fields(b) {
                        match field? {
                            (1, Value::Bytes(b)) => key = string(b)?,
                            (2, Value::Bytes(b)) => value = string(b)?,
                            _ => {}
                        }
                    }
                    model.metadata.insert(key, value);
                }
                _ => {}
            }
        }
        if graph {
            Ok(model)
        } else {
            Err("no graph".into())
        }
    }

    /// The graph input or output called `name`.
    pub fn value_info(&self, name: &str) -> Option<&ValueInfo> {
        self.inputs
            .iter()
            .chain(&self.outputs)
            .find(|v| v.name == name)
    }
}

fn parse_graph(bytes: &[u8], model: &mut Model) -> Result<(), String> {
    let mut inputs = Vec::new();
    for field in Fields(bytes) {
        match field? {
            (1, Value::Bytes(b)) => model.nodes.push(parse_node(b)?),
            (5, Value::Bytes(b)) => {
                let (name, tensor) = parse_tensor(b)?;
                model.initializers.insert(name, tensor);
            }
            (11, Value::Bytes(b)) => inputs.push(parse_value_info(b)?),
            (12, Value::Bytes(b)) => model.outputs.push(parse_value_info(b)?),
            _ => {}
        }
    }
    // Older files list the initializers among the inputs too.
    model.inputs = inputs
        .into_iter()
        .filter(|v| !model.initializers.contains_key(&v.name))
        .collect();
    Ok(())
}

fn parse_node(bytes: &[u8]) -> Result<Node, String> {
    let mut node = Node::default();
    for field in Fields(bytes) {
        match field? {
            (1, Value::Bytes(b)) => node.inputs.push(string(b)?),
            (2, Value::Bytes(b)) => node.outputs.push(string(b)?),
            (4, Value::Bytes(b)) => node.op = string(b)?,
            (5, Value::Bytes(b)) => {
                let (name, value) = parse_attribute(b)?;
                if let Some(value) = value {
                    node.attributes.insert(name, value);
                }
            }
            (7, Value::Bytes(b)) if !b.is_empty() && b != b"ai.onnx" => {
                return Err(format!("operator domain `{}` is not ONNX's", string(b)?));
            }
            _ => {}
        }
    }
    Ok(node)
}

/// (name, value); `None` for attribute kinds no supported operator takes (graphs, lists of
/// strings or tensors).
fn parse_attribute(bytes: &[u8]) -> Result<(String, Option<Attribute>), String> {
    let (mut name, mut kind) = (String::new(), 0);
    let (mut f, mut i, mut s, mut t) = (None, None, None, None);
    let (mut floats, mut ints) = (Vec::new(), Vec::new());
    for field in Fields(bytes) {
        match field? {
            (1, Value::Bytes(b)) => name = string(b)?,
            (2, Value::Fixed32(v)) => f = Some(f32::from_bits(v)),
            (3, Value::Varint(v)) => i = Some(v as i64),
            (4, Value::Bytes(b)) => s = Some(string(b)?),
            (5, Value::Bytes(b)) => t = Some(parse_tensor(b)?.1),
            (7, v) => floats.extend(fixed32s(v)?.into_iter().map(f32::from_bits)),
            (8, v) => ints.extend(varints(v)?.into_iter().map(|v| v as i64)),
            (20, Value::Varint(v)) => kind = v,
            _ => {}
        }
    }
    // AttributeProto.AttributeType: FLOAT 1, INT 2, STRING 3, TENSOR 4, FLOATS 6, INTS 7.
    let value = match kind {
        1 => f.or(Some(0.0)).map(Attribute::Float),
        2 => i.or(Some(0)).map(Attribute::Int),
        3 => s.map(Attribute::String),
        4 => t.map(Attribute::Tensor),
        6 => Some(Attribute::Floats(floats)),
        7 => Some(Attribute::Ints(ints)),
        _ => None,
    };
    Ok((name, value))
}

fn parse_tensor(bytes: &[u8]) -> Result<(String, Tensor), String> {
    let (mut name, mut data_type, mut external) = (String::new(), 0, false);
    let (mut dims, mut raw, mut floats, mut ints) = (Vec::new(), None, Vec::new(), Vec::new());
    for field in Fields(bytes) {
        match field? {
            (1, v) => dims.extend(varints(v)?.into_iter().map(|v| v as i64)),
            (2, Value::Varint(v)) => data_type = v,
            (4, v) => floats.extend(fixed32s(v)?.into_iter().map(f32::from_bits)),
            (7, v) => ints.extend(varints(v)?.into_iter().map(|v| v as i64)),
            (8, Value::Bytes(b)) => name = string(b)?,
            (9, Value::Bytes(b)) => raw = Some(b),
            (14, Value::Varint(1)) => external = true,
            _ => {}
        }
    }
    if external {
        return Err(format!("tensor `{name}` keeps its data in another file"));
    }
    let count = dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(usize::try_from(d).ok()?))
        .ok_or_else(|| format!("tensor `{name}` has dims {dims:?}"))?;
    // TensorProto.DataType: FLOAT 1, INT64 7.
    let data = match (data_type, raw) {
        (1, Some(raw)) => TensorData::F32(bytemuck::pod_collect_to_vec(raw)),
        (1, None) => TensorData::F32(floats),
        (7, Some(raw)) => TensorData::I64(bytemuck::pod_collect_to_vec(raw)),
        (7, None) => TensorData::I64(ints),
        (other, _) => {
            return Err(format!(
                "tensor `{name}` has data type {other} (only float32 and int64 are read)"
            ));
        }
    };
    let len = match &data {
        TensorData::F32(v) => v.len(),
        TensorData::I64(v) => v.len(),
    };
    if len != count {
        return Err(format!(
            "tensor `{name}` holds {len} values for dims {dims:?}"
        ));
    }
    Ok((name, Tensor { dims, data }))
}

/// ValueInfoProto { name 1, type 2 { tensor_type 1 { shape 2 { dim 1 { value 1 | param 2 } } } } }.
fn parse_value_info(bytes: &[u8]) -> Result<ValueInfo, String> {
    let mut info = ValueInfo::default();
    for field in Fields(bytes) {
        match field? {
            (1, Value::Bytes(b)) => info.name = string(b)?,
            (2, Value::Bytes(b)) => {
                let tensor = first_message(b, 1)?;
                let shape = first_message(tensor, 2)?;
                for dim in Fields(shape) {
                    if let (1, Value::Bytes(d)) = dim? {
                        let mut value = None;
                        for field in Fields(d) {
                            if let (1, Value::Varint(v)) = field? {
                                value = Some(v as i64);
                            }
                        }
                        info.dims.push(value);
                    }
                }
            }
            _ => {}
        }
    }
    Ok(info)
}

/// The payload of a message's field `number` (empty if absent).
fn first_message(bytes: &[u8], number: u32) -> Result<&[u8], String> {
    for field in Fields(bytes) {
        if let (n, Value::Bytes(b)) = field?
            && n == number
        {
            return Ok(b);
        }
    }
    Ok(&[])
}

fn string(bytes: &[u8]) -> Result<String, String> {
    String::from_utf8(bytes.to_vec()).map_err(|_| "a name is not UTF-8".into())
}

/// A repeated varint field, packed or not.
fn varints(value: Value) -> Result<Vec<u64>, String> {
    match value {
        Value::Varint(v) => Ok(vec![v]),
        Value::Bytes(mut b) => {
            let mut out = Vec::new();
            while !b.is_empty() {
                out.push(varint(&mut b)?);
            }
            Ok(out)
        }
        _ => Err("an integer list has the wrong wire type".into()),
    }
}

/// A repeated 32-bit field, packed or not.
fn fixed32s(value: Value) -> Result<Vec<u32>, String> {
    match value {
        Value::Fixed32(v) => Ok(vec![v]),
        Value::Bytes(b) if b.len() % 4 == 0 => Ok(bytemuck::pod_collect_to_vec(b)),
        _ => Err("a float list has the wrong wire type or length".into()),
    }
}

/// A field's payload by wire type.
enum Value<'a> {
    Varint(u64),
    Fixed64,
    Bytes(&'a [u8]),
    Fixed32(u32),
}

/// The fields of one message, in order: (field number, payload).
struct Fields<'a>(&'a [u8]);

impl<'a> Iterator for Fields<'a> {
    type Item = Result<(u32, Value<'a>), String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.0.is_empty() {
            return None;
        }
        let item = self.field();
        if item.is_err() {
            self.0 = &[];
        }
        Some(item)
    }
}

impl<'a> Fields<'a> {
    fn field(&mut self) -> Result<(u32, Value<'a>), String> {
        let key = varint(&mut self.0)?;
        let number = (key >> 3) as u32;
        let value = match key & 7 {
            0 => Value::Varint(varint(&mut self.0)?),
            1 => {
                self.take(8)?;
                Value::Fixed64
            }
            2 => {
                let len = varint(&mut self.0)? as usize;
                Value::Bytes(self.take(len)?)
            }
            5 => Value::Fixed32(u32::from_le_bytes(
                self.take(4)?.try_into().expect("took 4"),
            )),
            other => return Err(format!("field {number} has wire type {other}")),
        };
        Ok((number, value))
    }

    fn take(&mut self, len: usize) -> Result<&'a [u8], String> {
        if len > self.0.len() {
            return Err("the file ends inside a field".into());
        }
        let (head, tail) = self.0.split_at(len);
        self.0 = tail;
        Ok(head)
    }
}

fn varint(bytes: &mut &[u8]) -> Result<u64, String> {
    let mut value = 0u64;
    for shift in (0..64).step_by(7) {
        let (&byte, rest) = bytes.split_first().ok_or("the file ends inside a number")?;
        *bytes = rest;
        value |= u64::from(byte & 0x7f) << shift;
        if byte & 0x80 == 0 {
            return Ok(value);
        }
    }
    Err("a number runs past 64 bits".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_refiner_reads_as_its_network() {
        let graph = Model::read(Path::new(crate::refine::DEFAULT_REFINER)).expect("readable");
        let splat = &graph.inputs[0];
        assert_eq!((graph.inputs.len(), splat.name.as_str()), (1, "splat"));
        assert_eq!(splat.dims, [Some(1), Some(5), None, None]);
        assert_eq!(graph.outputs[0].name, "refined");
        assert!(graph.metadata["description"].starts_with("default refiner"));
        let convs: Vec<_> = graph.nodes.iter().filter(|n| n.op == "Conv").collect();
        assert_eq!(convs.len(), 10);
        assert_eq!(
            convs[2].attributes.get("strides"),
            Some(&Attribute::Ints(vec![2, 2]))
        );
        let w = &graph.initializers["enc0.0.weight"];
        assert_eq!(w.dims, [16, 5, 3, 3]);
        let parameters: usize = graph
            .initializers
            .values()
            .map(|t| t.dims.iter().product::<i64>() as usize)
            .sum();
        // The count the training script wrote into the model's description.
        assert_eq!(parameters, 116_804);
    }

    #[test]
    fn a_truncated_file_is_an_error_not_a_panic() {
        let bytes = std::fs::read(crate::refine::DEFAULT_REFINER).expect("shipped");
        for cut in [1, 7, 100, bytes.len() / 2, bytes.len() - 1] {
            assert!(Model::parse(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        assert!(Model::parse(b"not a model at all").is_err());
    }
}
