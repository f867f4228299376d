//! `rome certs DIR`: the credentials of a deployment with access control,
//! so neither tests nor users need an openssl recipe.
//!
//! ```text
//! rome certs /etc/rome/secrets         # router, observer, operator, data, sim, r1, r2
//! rome certs secrets --names router,operator,r1,r2,r3 --hosts router.lan,10.0.0.1
//! ```
//!
//! Writes, in DIR:
//!
//! ```text
//! ca.pem, ca-key.pem          the deployment's authority (keep the key off the robots)
//! NAME.pem, NAME-key.pem      each name's certificate (CN=NAME, valid for --hosts) and key
//! NAME.password               each name's password (user name NAME)
//! users.txt                   NAME:password for every name: the router's dictionary
//! ```
//!
//! An existing authority in DIR is kept and signs the new names, so a robot
//! added later joins the same deployment; existing names are left alone
//! unless `--force`. Keys and passwords are readable by their owner only.

use anyhow::Context;
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Flags of `rome certs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The directory to write into (made if missing).
    pub dir: PathBuf,
    /// The names to make credentials for: roles, robots, and the router.
    #[arg(long, value_delimiter = ',', default_values_t = ["router", "observer", "operator", "data", "sim", "r1", "r2"].map(String::from))]
    pub names: Vec<String>,
    /// Host names and addresses the certificates are valid for: those the
    /// router is reached by (and any listening peer's).
    #[arg(long, value_delimiter = ',', default_values_t = ["router.lan", "localhost", "127.0.0.1"].map(String::from))]
    pub hosts: Vec<String>,
    /// Days the certificates stay valid.
    #[arg(long, default_value_t = 825)]
    pub days: u32,
    /// Make new credentials for names that already have some.
    #[arg(long)]
    pub force: bool,
}

/// Writes `text` to `path`, readable by its owner only when `secret`.
fn write(path: &Path, text: &str, secret: bool) -> anyhow::Result<()> {
    use std::io::Write;
    let mut options = std::fs::OpenOptions::new();
    options.create(true).write(true).truncate(true);
    #[cfg(unix)]
    if secret {
        use std::os::unix::fs::OpenOptionsExt;
        options.mode(0o600);
    }
    let mut f = options
        .open(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    f.write_all(text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// 24 random characters from the operating system's generator.
fn password() -> anyhow::Result<String> {
    const ALPHABET: &[u8] = b"abcdefghijkmnopqrstuvwxyzABCDEFGHJKLMNPQRSTUVWXYZ23456789";
    let mut bytes = [0u8; 24];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("cannot read /dev/urandom for passwords")?;
    Ok(bytes
        .iter()
        .map(|b| ALPHABET[*b as usize % ALPHABET.len()] as char)
        .collect())
}

/// Valid from a day ago (clocks of robots drift) for `days` days.
fn validity(params: &mut CertificateParams, days: u32) {
    let now = time::OffsetDateTime::now_utc();
    params.not_before = now - time::Duration::days(1);
    params.not_after = now + time::Duration::days(i64::from(days));
}

/// The authority in `dir`, loaded or made.
fn authority(dir: &Path, days: u32) -> anyhow::Result<Issuer<'static, KeyPair>> {
    let (cert, key) = (dir.join("ca.pem"), dir.join("ca-key.pem"));
    if cert.is_file() && key.is_file() {
        let cert_pem = std::fs::read_to_string(&cert)?;
        let key = KeyPair::from_pem(&std::fs::read_to_string(&key)?)
            .with_context(|| format!("{} is not a private key", key.display()))?;
        eprintln!("using the authority in {}", cert.display());
        return Issuer::from_ca_cert_pem(&cert_pem, key)
            .with_context(|| format!("{} is not a CA certificate", cert.display()));
    }
    let mut params = CertificateParams::new(Vec::<String>::new())?;
    params
        .distinguished_name
        .push(DnType::CommonName, "RoME deployment authority");
    params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    params.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    validity(&mut params, days);
    let key_pair = KeyPair::generate()?;
    let ca = params.self_signed(&key_pair)?;
    write(&cert, &ca.pem(), false)?;
    write(&dir.join("ca-key.pem"), &key_pair.serialize_pem(), true)?;
    eprintln!("made an authority: {}", cert.display());
    Ok(Issuer::new(params, key_pair))
}

/// Reads `users.txt` (name:password per line) if there is one.
fn users(path: &Path) -> anyhow::Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    if path.is_file() {
        for line in std::fs::read_to_string(path)?.lines() {
            if let Some((name, pw)) = line.split_once(':') {
                out.insert(name.to_string(), pw.to_string());
            }
        }
    }
    Ok(out)
}

/// Makes the credentials.
pub fn run(args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(!args.names.is_empty(), "--names needs at least one name");
    for name in &args.names {
        rome_schema::Name::new(name.as_str())
            .ok()
            .filter(|_| !name.contains('/'))
            .with_context(|| {
                format!("'{name}' cannot be a name: one key chunk (letters, digits, - _)")
            })?;
    }
    anyhow::ensure!(
        (1..=3650).contains(&args.days),
        "--days must be between 1 and 3650"
    );
    std::fs::create_dir_all(&args.dir)
        .with_context(|| format!("cannot create {}", args.dir.display()))?;
    let issuer = authority(&args.dir, args.days)?;
    let users_file = args.dir.join("users.txt");
    let mut users = users(&users_file)?;
    for name in &args.names {
        let cert_path = args.dir.join(format!("{name}.pem"));
        if cert_path.is_file() && !args.force {
            eprintln!("{name}: kept (--force makes new ones)");
            continue;
        }
        let mut params = CertificateParams::new(args.hosts.clone())
            .with_context(|| format!("--hosts {:?} has a name that is not valid", args.hosts))?;
        params.distinguished_name.push(DnType::CommonName, name);
        params.key_usages = vec![
            KeyUsagePurpose::DigitalSignature,
            KeyUsagePurpose::KeyEncipherment,
        ];
        params.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        validity(&mut params, args.days);
        let key = KeyPair::generate()?;
        let cert = params.signed_by(&key, &issuer)?;
        let pw = password()?;
        write(&cert_path, &cert.pem(), false)?;
        write(
            &args.dir.join(format!("{name}-key.pem")),
            &key.serialize_pem(),
            true,
        )?;
        write(
            &args.dir.join(format!("{name}.password")),
            &format!("{pw}\n"),
            true,
        )?;
        users.insert(name.clone(), pw);
        eprintln!("{name}: {}", cert_path.display());
    }
    let dictionary: String = users
        .iter()
        .map(|(name, pw)| format!("{name}:{pw}\n"))
        .collect();
    write(&users_file, &dictionary, true)?;
    println!(
        "credentials in {}; give each host ca.pem and its own NAME files, and the router users.txt",
        args.dir.display()
    );
    Ok(rome_common::exit::OK)
}
