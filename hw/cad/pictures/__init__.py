"""Pictures for people: part previews, assembly and build-guide images, and the build guide page itself."""
