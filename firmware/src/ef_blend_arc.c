/* Placeholder until the module lands. */
typedef int ef_blend_arc_placeholder_t;
