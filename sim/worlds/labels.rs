//! What a world's masks mean: its instances (a body with all its geoms; a geom of the world
//! body on its own) and their classes, as `labels.json` lists them.
//!
//! A class is the instance's name without its `_N` suffixes (`wall_3` -> `wall`,
//! `table_7` -> `table`): the generator and `world import` name what they place that way. A
//! hand-made world may name a class outright with a custom text,
//! `<custom><text name="class:INSTANCE" data="CLASS"/></custom>`, where INSTANCE is the body's
//! name (or a world geom's). The robot is never an instance, nor is a geom the camera cannot
//! see (groups 3-5: the robot, imported scenes' colliders).

use crate::error::{Result, SimError};
use crate::mujoco::{Model, ObjKind};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// The custom text prefix that names an instance's class outright.
pub const CLASS_TEXT_PREFIX: &str = "class:";

/// Geom groups the sensor renders (0-2): what the masks can show.
const VISIBLE_GROUPS: std::ops::RangeInclusive<i32> = 0..=2;

/// One class of `labels.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelClass {
    /// The semantic mask's value (1..).
    pub id: u16,
    /// The class name (`wall`, `table`).
    pub name: String,
}

/// A geom an instance is made of.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelGeom {
    /// MuJoCo's geom id in the world's compiled model.
    pub id: usize,
    /// Its name, when it has one.
    pub name: Option<String>,
}

/// One instance of `labels.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelInstance {
    /// The instance mask's value (1..).
    pub id: u16,
    /// The body's name (or the world geom's); `body_N` / `geom_N` for an unnamed one.
    pub name: String,
    /// Its class id.
    pub class: u16,
    /// The geoms it is made of.
    pub geoms: Vec<LabelGeom>,
}

/// `labels.json`: the classes and instances of a world, and the lookups from a geom to its
/// instance and from an instance to its class that turn a segmentation render into masks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Labels {
    /// Every class, ids from 1 (0 = nothing).
    pub classes: Vec<LabelClass>,
    /// Every instance, ids from 1 (0 = nothing).
    pub instances: Vec<LabelInstance>,
    /// Instance id of each geom of the model (0: the robot's, or not seen by the camera).
    #[serde(skip)]
    geom_instance: Vec<u16>,
}

/// Who an instance is: a body, or a geom of the world body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Owner {
    Body(usize),
    WorldGeom(usize),
}

/// `name` without its `_N` suffixes: `wall_3` -> `wall`, `chair_001_4` -> `chair`; a name
/// that is nothing but a number stays as it is.
pub fn class_of_name(name: &str) -> &str {
    let mut class = name;
    while let Some((stem, number)) = class.rsplit_once('_') {
        if stem.is_empty() || number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
            break;
        }
        class = stem;
    }
    class
}

impl Labels {
    /// The labels of `model`, leaving out the subtree of `robot_body`. Fails when the world
    /// has more instances or classes than a 16-bit mask holds.
    pub fn of_model(model: &Model, robot_body: usize) -> Result<Self> {
        let mut owners: HashMap<Owner, u16> = HashMap::new();
        let mut class_ids: HashMap<String, u16> = HashMap::new();
        let mut labels = Labels {
            classes: Vec::new(),
            instances: Vec::new(),
            geom_instance: vec![0; model.geom_count()],
        };
        let too_many = |what: &str| SimError::InvalidArgument {
            what: "masks",
            detail: format!(
                "{} has more {what} than a 16-bit mask holds ({}); run with --masks false",
                model.path().display(),
                u16::MAX
            ),
        };
        for geom in 0..model.geom_count() {
            let body = model.geom_body(geom);
            if !VISIBLE_GROUPS.contains(&model.geom_group(geom))
                || (body != 0 && model.body_is_in_subtree(body, robot_body))
            {
                continue;
            }
            let owner = if body == 0 {
                Owner::WorldGeom(geom)
            } else {
                Owner::Body(body)
            };
            let id = match owners.get(&owner) {
                Some(&id) => id,
                None => {
                    let id = u16::try_from(labels.instances.len() + 1)
                        .map_err(|_| too_many("instances"))?;
                    let name = match owner {
                        Owner::Body(b) => model
                            .name(ObjKind::Body, b)
                            .unwrap_or_else(|| format!("body_{b}")),
                        Owner::WorldGeom(g) => model
                            .name(ObjKind::Geom, g)
                            .unwrap_or_else(|| format!("geom_{g}")),
                    };
                    let class_name = model
                        .custom_text(&format!("{CLASS_TEXT_PREFIX}{name}"))
                        .map(|c| c.trim().to_owned())
                        .filter(|c| !c.is_empty())
                        .unwrap_or_else(|| class_of_name(&name).to_owned());
                    let class = match class_ids.get(&class_name) {
                        Some(&c) => c,
                        None => {
                            let c = u16::try_from(labels.classes.len() + 1)
                                .map_err(|_| too_many("classes"))?;
                            class_ids.insert(class_name.clone(), c);
                            labels.classes.push(LabelClass {
                                id: c,
                                name: class_name,
                            });
                            c
                        }
                    };
                    labels.instances.push(LabelInstance {
                        id,
                        name,
                        class,
                        geoms: Vec::new(),
                    });
                    owners.insert(owner, id);
                    id
                }
            };
            labels.geom_instance[geom] = id;
            labels.instances[usize::from(id) - 1].geoms.push(LabelGeom {
                id: geom,
                name: model.name(ObjKind::Geom, geom),
            });
        }
        Ok(labels)
    }

    /// The instance a geom belongs to (0 for none: no geom, the robot's, an invisible one).
    pub fn instance_of_geom(&self, geom: i32) -> u16 {
        usize::try_from(geom)
            .ok()
            .and_then(|g| self.geom_instance.get(g))
            .copied()
            .unwrap_or(0)
    }

    /// The semantic mask of an instance mask.
    pub fn semantic(&self, instance: &[u16]) -> Vec<u16> {
        let classes: Vec<u16> = std::iter::once(0)
            .chain(self.instances.iter().map(|i| i.class))
            .collect();
        instance
            .iter()
            .map(|&i| classes.get(usize::from(i)).copied().unwrap_or(0))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::class_of_name;

    #[test]
    fn a_class_is_the_name_without_its_number_suffixes() {
        assert_eq!(class_of_name("wall_3"), "wall");
        assert_eq!(class_of_name("table_7"), "table");
        assert_eq!(class_of_name("chair_001_4"), "chair");
        assert_eq!(class_of_name("wall_north"), "wall_north");
        assert_eq!(class_of_name("floor"), "floor");
        assert_eq!(class_of_name("_3"), "_3");
        assert_eq!(class_of_name("12"), "12");
        assert_eq!(class_of_name("sofa_3_seat"), "sofa_3_seat");
        assert_eq!(class_of_name("x_"), "x_");
    }
}
