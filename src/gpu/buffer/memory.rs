//! Which memory type a buffer takes: the preferences per use and [`place`], a pure function of
//! the device's memory properties (tested below on lavapipe's, an integrated and a discrete GPU's
//! memory types).

use ash::vk;

/// What a buffer is for, which decides its memory type ([`place`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryUse {
    /// Written by the host, read by a kernel (parameters, directions, nodes).
    Input,
    /// Written by a kernel, read back by the host (table cells, partial sums, pixels).
    Output,
}

const DL: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
const HV: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_VISIBLE;
const HC: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_COHERENT;
const CA: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::HOST_CACHED;

const fn or(flags: &[vk::MemoryPropertyFlags]) -> vk::MemoryPropertyFlags {
    let mut raw = 0;
    let mut k = 0;
    while k < flags.len() {
        raw |= flags[k].as_raw();
        k += 1;
    }
    vk::MemoryPropertyFlags::from_raw(raw)
}

/// The memory types `use_` accepts for a buffer the host maps and a kernel binds (no staging),
/// best first: device-local and mapped (with HOST_CACHED for outputs). The last entries, plain
/// host-visible memory, serve only a device without any device-local type.
pub fn memory_preferences(use_: MemoryUse) -> &'static [vk::MemoryPropertyFlags] {
    const IN: &[vk::MemoryPropertyFlags] = &[or(&[DL, HV, HC]), or(&[HV, HC])];
    const OUT: &[vk::MemoryPropertyFlags] = &[
        or(&[DL, HV, HC, CA]),
        or(&[HV, HC, CA]),
        or(&[DL, HV, HC]),
        or(&[HV, HC]),
    ];
    match use_ {
        MemoryUse::Input => IN,
        MemoryUse::Output => OUT,
    }
}

/// The memory types a staging buffer for `use_` accepts, best first: any host-visible coherent
/// memory for uploads (write-combined is fine for a sequential write), host-cached memory for
/// read-backs.
pub fn staging_preferences(use_: MemoryUse) -> &'static [vk::MemoryPropertyFlags] {
    const IN: &[vk::MemoryPropertyFlags] = &[or(&[HV, HC])];
    const OUT: &[vk::MemoryPropertyFlags] = &[or(&[HV, HC, CA]), or(&[HV, HC])];
    match use_ {
        MemoryUse::Input => IN,
        MemoryUse::Output => OUT,
    }
}

/// The first of `prefs` that some type in `type_bits` has, the lowest such index.
pub(super) fn first_of(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    prefs: &[vk::MemoryPropertyFlags],
) -> Option<u32> {
    prefs.iter().find_map(|&flags| {
        (0..props.memory_type_count.min(vk::MAX_MEMORY_TYPES as u32)).find(|&i| {
            type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    })
}

/// The memory type a directly mapped buffer for `use_` takes among `type_bits` (the buffer's
/// allowed types) of a device with memory properties `props`: the first of
/// [`memory_preferences`] that some type has, the lowest such index; None if no allowed type is
/// host-visible and coherent.
pub fn choose_memory(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    use_: MemoryUse,
) -> Option<u32> {
    first_of(props, type_bits, memory_preferences(use_))
}

/// Where a buffer's memory lives ([`place`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// One buffer, mapped by the host and bound by the kernel, of this memory type.
    Direct(u32),
    /// A device-local buffer the kernel binds (`device`, a memory type index) and a mapped
    /// staging buffer (`staging`) the host writes or reads, joined by a copy on the device.
    Staged {
        /// Memory type of the buffer the kernel binds.
        device: u32,
        /// Memory type of the host's staging buffer.
        staging: u32,
    },
}

/// Where a buffer for `use_` lives on a device with memory properties `props`, its kernel-side
/// buffer allowing the types `type_bits` and a staging buffer `staging_bits`: direct where a
/// device-local type serves the use mapped (host-visible for inputs, host-visible and cached for
/// outputs), else staged through device-local memory, and also staged when `force_staging` (if
/// the device has device-local memory at all). A device without device-local memory maps plain
/// host-visible memory. None if nothing fits.
pub fn place(
    props: &vk::PhysicalDeviceMemoryProperties,
    type_bits: u32,
    staging_bits: u32,
    use_: MemoryUse,
    force_staging: bool,
) -> Option<Placement> {
    let best = memory_preferences(use_)[0];
    if !force_staging {
        if let Some(t) = first_of(props, type_bits, &[best]) {
            return Some(Placement::Direct(t));
        }
    }
    match first_of(props, type_bits, &[DL]) {
        Some(device) => first_of(props, staging_bits, staging_preferences(use_))
            .map(|staging| Placement::Staged { device, staging }),
        None => choose_memory(props, type_bits, use_).map(Placement::Direct),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn props(types: &[vk::MemoryPropertyFlags]) -> vk::PhysicalDeviceMemoryProperties {
        let mut p = vk::PhysicalDeviceMemoryProperties {
            memory_type_count: types.len() as u32,
            ..Default::default()
        };
        for (t, &f) in p.memory_types.iter_mut().zip(types) {
            t.property_flags = f;
        }
        p
    }

    use MemoryUse::{Input, Output};
    use Placement::{Direct, Staged};

    #[test]
    fn lavapipe_maps_one_memory_type_for_everything() {
        // Mesa lavapipe: a single type, device-local, host-visible, coherent and cached.
        let p = props(&[DL | HV | HC | CA]);
        assert_eq!(place(&p, 1, 1, Input, false), Some(Direct(0)));
        assert_eq!(place(&p, 1, 1, Output, false), Some(Direct(0)));
        // Forced staging binds the same type and stages through it.
        let both = Some(Staged {
            device: 0,
            staging: 0,
        });
        assert_eq!(place(&p, 1, 1, Input, true), both);
        assert_eq!(place(&p, 1, 1, Output, true), both);
    }

    #[test]
    fn a_discrete_gpu_stages_outputs_to_cached_memory_and_writes_inputs_through_the_bar() {
        // The types of a discrete GPU with resizable BAR (as NVIDIA drivers list them):
        // 0 device-local only, 1 host-visible coherent (write-combined system memory),
        // 2 host-visible coherent cached (system memory), 3 device-local host-visible (BAR).
        let p = props(&[DL, HV | HC, HV | HC | CA, DL | HV | HC]);
        assert_eq!(place(&p, 0b1111, 0b1111, Input, false), Some(Direct(3)));
        assert_eq!(
            place(&p, 0b1111, 0b1111, Output, false),
            Some(Staged {
                device: 0,
                staging: 2
            })
        );
        // Without the BAR type, inputs are staged through write-combined system memory.
        assert_eq!(
            place(&p, 0b0111, 0b0111, Input, false),
            Some(Staged {
                device: 0,
                staging: 1
            })
        );
        // Staging needs a host-visible type for the staging buffer.
        assert_eq!(place(&p, 0b0001, 0b0001, Output, false), None);
    }

    #[test]
    fn an_integrated_gpu_maps_cached_device_local_memory() {
        // A unified-memory GPU: 0 device-local, 1 device-local host-visible coherent cached.
        let p = props(&[DL, DL | HV | HC | CA]);
        assert_eq!(place(&p, 0b11, 0b11, Input, false), Some(Direct(1)));
        assert_eq!(place(&p, 0b11, 0b11, Output, false), Some(Direct(1)));
    }

    #[test]
    fn a_device_without_device_local_memory_maps_host_memory() {
        let p = props(&[HV | HC]);
        assert_eq!(place(&p, 1, 1, Input, true), Some(Direct(0)));
        assert_eq!(place(&p, 1, 1, Output, false), Some(Direct(0)));
        assert_eq!(choose_memory(&p, 1, Output), Some(0));
    }
}
