/* placeholder until implemented */
typedef int ef_placeholder_ef_table_parse_t;
