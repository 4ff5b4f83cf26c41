/* Placeholder until the module lands. */
typedef int ef_interp_placeholder_t;
