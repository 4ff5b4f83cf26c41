/* Placeholder until the module lands. */
typedef int ef_prim_placeholder_t;
