// TEMPORARY: replaced by node_physics.cpp once the CiA 404 control surface lands.
#include "control/service_internal.hpp"
namespace cansim::control {
int node_hold(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_step(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_ramp(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_set_model(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_restore_model(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_override(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_clear_override(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_arm_fault(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_cancel_fault(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_list_faults(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_start_recording(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_stop_recording(sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_get_channel(sd_bus*, const char*, const char*, const char*, sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_get_overrides(sd_bus*, const char*, const char*, const char*, sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_get_faults(sd_bus*, const char*, const char*, const char*, sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
int node_get_recording(sd_bus*, const char*, const char*, const char*, sd_bus_message*, void*, sd_bus_error* e) { return fail(e, kErrorNotSupported, "not yet"); }
}
