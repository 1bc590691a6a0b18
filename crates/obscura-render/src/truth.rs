//! Ground truth per sample and the scene's ID table: both depths, camera-space position and normal,
//! and integer object, instance and material IDs with their names.
//!
//! # IDs
//!
//! `0` means nothing was hit. Every object in the scene (an entry of [`Scene::objects`]) is one
//! **instance**, `instanceId = index + 1`; instances sharing an object name (a glTF mesh placed by two
//! nodes, an OBJ group split over materials, RIB shapes under one `Attribute "identifier" "name"`) share
//! one **object**, numbered from 1 in the order the names first appear; an instance without a name is an
//! object of its own. `materialId = material index + 1` (index 0 is the default material). IDs are
//! integers, stored as `UINT` EXR channels and never filtered: each pixel holds the IDs of the sample
//! nearest its centre, the same sample as `Z`.

use obscura_scene::Scene;
use serde_json::{Value, json};

/// The scene's IDs and names (see the module documentation).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IdTable {
    /// `objectId` of each instance (index = instance index).
    instance_object: Vec<u32>,
    /// `materialId` of each instance.
    instance_material: Vec<u32>,
    /// Object names, `objects[id − 1]`.
    objects: Vec<String>,
    /// Instance names and where each was declared, `instances[id − 1]`.
    instances: Vec<(String, String)>,
    /// Material names, `materials[id − 1]`.
    materials: Vec<String>,
}

impl IdTable {
    /// The IDs of `scene`'s objects. An instance without an object name becomes its own object, named
    /// after its source location; one without an instance name is named after its object.
    #[must_use]
    pub fn new(scene: &Scene) -> Self {
        let mut t = IdTable::default();
        for o in &scene.objects {
            let object_name = if o.identity.object.is_empty() {
                None
            } else {
                Some(o.identity.object.clone())
            };
            let id = match object_name
                .as_ref()
                .and_then(|n| t.objects.iter().position(|m| m == n))
            {
                Some(i) => i as u32 + 1,
                None => {
                    t.objects.push(object_name.unwrap_or_else(|| o.source.clone()));
                    t.objects.len() as u32
                }
            };
            t.instance_object.push(id);
            t.instance_material.push(o.material + 1);
            let name = if o.identity.instance.is_empty() {
                t.objects[id as usize - 1].clone()
            } else {
                o.identity.instance.clone()
            };
            t.instances.push((name, o.source.clone()));
        }
        t.materials = (0..scene.materials.len())
            .map(|i| {
                if i == 0 {
                    "default".to_string()
                } else {
                    format!("material {i}")
                }
            })
            .collect();
        t
    }

    /// How many instances (scene objects) the table numbers.
    #[must_use]
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// `(objectId, instanceId, materialId)` of instance `instance` (an index into the scene's objects).
    #[must_use]
    pub fn ids(&self, instance: u32) -> (u32, u32, u32) {
        let i = instance as usize;
        match (self.instance_object.get(i), self.instance_material.get(i)) {
            (Some(&o), Some(&m)) => (o, instance + 1, m),
            _ => (0, 0, 0),
        }
    }

    /// The name of object `object_id` (from 1); `None` for 0 or an unknown ID.
    #[must_use]
    pub fn object_name(&self, object_id: u32) -> Option<&str> {
        let i = (object_id as usize).checked_sub(1)?;
        self.objects.get(i).map(String::as_str)
    }

    /// The name of instance `instance_id` (from 1); `None` for 0 or an unknown ID.
    #[must_use]
    pub fn instance_name(&self, instance_id: u32) -> Option<&str> {
        let i = (instance_id as usize).checked_sub(1)?;
        self.instances.get(i).map(|(n, _)| n.as_str())
    }

    /// The table as JSON: `{"objects": {"<id>": "name"}, "instances": {"<id>": {"name", "object",
    /// "material", "source"}}, "materials": {"<id>": "name"}, "background": 0}`.
    #[must_use]
    pub fn to_json(&self) -> Value {
        let objects: serde_json::Map<String, Value> = (self.objects.iter().enumerate())
            .map(|(i, n)| ((i + 1).to_string(), json!(n)))
            .collect();
        let instances: serde_json::Map<String, Value> = (self.instances.iter().enumerate())
            .map(|(i, (n, source))| {
                (
                    (i + 1).to_string(),
                    json!({
                        "name": n,
                        "object": self.instance_object[i],
                        "material": self.instance_material[i],
                        "source": source,
                    }),
                )
            })
            .collect();
        let materials: serde_json::Map<String, Value> = (self.materials.iter().enumerate())
            .map(|(i, n)| ((i + 1).to_string(), json!(n)))
            .collect();
        json!({
            "background": 0,
            "objects": objects,
            "instances": instances,
            "materials": materials,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_host::CameraDesc;
    use obscura_scene::{Identity, MotionTransform, Object, Shape};
    use obscura_sdk::Format;

    fn object(object: &str, instance: &str, source: &str) -> Object {
        Object {
            shape: Shape::Sphere {
                radius: 1.0,
                z_min: -1.0,
                z_max: 1.0,
                theta_max: 360.0,
            },
            transform: MotionTransform::default(),
            material: 0,
            micropolygon_length: 1.0,
            source: source.into(),
            sides: Default::default(),
            visibility: Default::default(),
            identity: Identity {
                object: object.into(),
                instance: instance.into(),
            },
        }
    }

    #[test]
    fn instances_of_one_named_object_share_its_id_and_unnamed_ones_are_their_own() {
        let mut s = Scene::new(CameraDesc::new(Format::new(4, 4)));
        s.objects = vec![
            object("teapot", "left", "a:1"),
            object("", "", "a:2"),
            object("teapot", "right", "a:3"),
            object("", "", "a:4"),
        ];
        s.objects[3].material = 0;
        let t = IdTable::new(&s);
        assert_eq!(t.ids(0), (1, 1, 1));
        assert_eq!(t.ids(1), (2, 2, 1));
        assert_eq!(t.ids(2), (1, 3, 1));
        assert_eq!(t.ids(3), (3, 4, 1));
        assert_eq!(t.ids(9), (0, 0, 0));
        let j = t.to_json();
        assert_eq!(j["objects"]["1"], "teapot");
        assert_eq!(j["objects"]["2"], "a:2");
        assert_eq!(j["instances"]["3"]["name"], "right");
        assert_eq!(j["instances"]["3"]["object"], 1);
        assert_eq!(j["instances"]["2"]["name"], "a:2");
    }
}
