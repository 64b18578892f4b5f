"""Files: meshes and volumes read, checked and written atomically. Imports only the runtime."""
